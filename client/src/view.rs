use lumen_proto::wire::{ContactsHeader, Status};
use lumen_proto::Contact;

/// One contacts reply, borrowed from the session (iceoryx2: straight from shared memory).
#[derive(Debug, Clone, Copy)]
pub struct ContactsView<'a> {
    pub(crate) header: &'a ContactsHeader,
    pub(crate) contacts: &'a [Contact],
}

impl<'a> ContactsView<'a> {
    /// The reply header (frame number, status, detection time, echoed client time...).
    pub fn header(&self) -> &'a ContactsHeader {
        self.header
    }
    /// The contacts, ordered by pair then rod sample (empty on error).
    pub fn contacts(&self) -> &'a [Contact] {
        self.contacts
    }
    /// The frame this answers.
    pub fn frame(&self) -> u64 {
        self.header.frame
    }
    /// `Ok(())` if the frame was processed, else the status and the daemon's explanation.
    pub fn result(&self) -> Result<(), (Status, &'a str)> {
        match self.header.status() {
            Some(Status::Ok) => Ok(()),
            Some(s) => Err((s, self.header.message())),
            None => Err((Status::Internal, "unknown status code")),
        }
    }
    /// Detection time in microseconds.
    pub fn detect_us(&self) -> f64 {
        self.header.detect_ns as f64 / 1e3
    }
    /// Round trip in microseconds, if the frame was stamped with [`crate::now_ns`].
    pub fn round_trip_us(&self) -> f64 {
        crate::now_ns().saturating_sub(self.header.client_time_ns) as f64 / 1e3
    }
}
