//! iceoryx2 `ZeroCopySend` for the wire types (feature `iceoryx2`, enabled only by the daemon and
//! the client), with stable type names that other languages declare to interoperate:
//!
//! | Rust type | iceoryx2 type name | size | align |
//! |---|---|---|---|
//! | [`FrameHeader`] (user header of the frame service) | `lumen::FrameHeader` | 40 | 8 |
//! | `f32` (frame payload slice element) | `f32` | 4 | 4 |
//! | [`ContactsHeader`] (user header of the contacts service) | `lumen::ContactsHeader` | 256 | 8 |
//! | [`Contact`] (contacts payload slice element) | `lumen::Contact` | 88 | 4 |

use crate::contact::Contact;
use crate::wire::{ContactsHeader, FrameHeader};
use iceoryx2::prelude::ZeroCopySend;

/// iceoryx2 type name of [`FrameHeader`].
pub const FRAME_HEADER_TYPE: &str = "lumen::FrameHeader";
/// iceoryx2 type name of [`ContactsHeader`].
pub const CONTACTS_HEADER_TYPE: &str = "lumen::ContactsHeader";
/// iceoryx2 type name of [`Contact`].
pub const CONTACT_TYPE: &str = "lumen::Contact";

// SAFETY: all three are #[repr(C)], hold only integers, floats and arrays of them (no pointers,
// no references, no padding that could leak), and are the same in every process.
unsafe impl ZeroCopySend for FrameHeader {
    unsafe fn type_name() -> &'static str {
        FRAME_HEADER_TYPE
    }
}
unsafe impl ZeroCopySend for ContactsHeader {
    unsafe fn type_name() -> &'static str {
        CONTACTS_HEADER_TYPE
    }
}
unsafe impl ZeroCopySend for Contact {
    unsafe fn type_name() -> &'static str {
        CONTACT_TYPE
    }
}
