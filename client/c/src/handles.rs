//! The handles C holds, checked before every use: a NULL, freed, foreign or wrong-kind pointer
//! is `LUMEN_STATUS_BAD_HANDLE`, not a crash (a table of live addresses rather than a magic
//! number inside the object, so a freed handle is never read).

use crate::error::Error;
use std::collections::BTreeMap;
use std::sync::{Mutex, PoisonError};
use std::thread::ThreadId;

/// What a handle is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Detector,
    Client,
    Session,
    Observer,
}

/// Live handles: address -> kind.
static LIVE: Mutex<BTreeMap<usize, Kind>> = Mutex::new(BTreeMap::new());

fn live() -> std::sync::MutexGuard<'static, BTreeMap<usize, Kind>> {
    // The table holds plain data: a panic elsewhere while it was locked leaves it consistent.
    LIVE.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Boxes `value` and registers its address as a live handle of `kind`.
pub(crate) fn register<T>(value: T, kind: Kind) -> *mut T {
    let ptr = Box::into_raw(Box::new(value));
    live().insert(ptr as usize, kind);
    ptr
}

fn check<T>(ptr: *const T, kind: Kind, name: &'static str) -> Result<(), Error> {
    if ptr.is_null() {
        return Err(Error::NullArgument(name));
    }
    match live().get(&(ptr as usize)) {
        Some(k) if *k == kind => Ok(()),
        Some(k) => Err(Error::BadHandle { name, detail: format!("it is a {k:?} handle, not a {kind:?} one") }),
        None => Err(Error::BadHandle { name, detail: "not a live handle (freed already, or never made by lumen)".into() }),
    }
}

/// The object behind a live handle of `kind`.
///
/// # Safety
/// No other call uses or frees the same handle meanwhile (the API's thread rule).
pub(crate) unsafe fn get<'a, T>(ptr: *mut T, kind: Kind, name: &'static str) -> Result<&'a mut T, Error> {
    check(ptr, kind, name)?;
    // SAFETY: registered by `register` and not yet released, so it points to a live `T`; the
    // caller guarantees exclusive use for the call.
    Ok(unsafe { &mut *ptr })
}

/// Unregisters a live handle of `kind` and gives its object back, to be dropped.
///
/// # Safety
/// As [`get`].
pub(crate) unsafe fn release<T>(ptr: *mut T, kind: Kind, name: &'static str) -> Result<Box<T>, Error> {
    let mut table = live();
    match table.get(&(ptr as usize)) {
        Some(k) if *k == kind => {
            table.remove(&(ptr as usize));
            // SAFETY: made by `Box::into_raw` in `register`, released once (just unregistered).
            Ok(unsafe { Box::from_raw(ptr) })
        }
        _ => {
            drop(table);
            let gone = || Error::BadHandle { name, detail: "not a live handle".into() };
            Err(check(ptr, kind, name).err().unwrap_or_else(gone))
        }
    }
}

/// The thread an iceoryx2 object belongs to; `None` for zenoh ones, which any thread may use.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Owner(Option<ThreadId>);

impl Owner {
    /// The calling thread when `local`, else any thread.
    pub(crate) fn new(local: bool) -> Self {
        Self(local.then(|| std::thread::current().id()))
    }

    /// `Ok` on the owning thread (or any, for zenoh objects).
    pub(crate) fn check(self, name: &'static str) -> Result<(), Error> {
        match self.0 {
            Some(id) if id != std::thread::current().id() => Err(Error::WrongThread(name)),
            _ => Ok(()),
        }
    }
}
