//! The handles C holds, checked before every use: a NULL, freed, foreign or wrong-kind pointer
//! is `LUMEN_STATUS_BAD_HANDLE`, not a crash (a table of live addresses rather than a magic
//! number inside the object, so a freed handle is never read).

use crate::error::Error;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
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

/// The object behind a live handle of `kind`, shared: for objects that guard themselves
/// against calls from two threads at once (the detector).
///
/// # Safety
/// No other call frees the same handle meanwhile.
pub(crate) unsafe fn shared<'a, T: Sync>(ptr: *const T, kind: Kind, name: &'static str) -> Result<&'a T, Error> {
    check(ptr, kind, name)?;
    // SAFETY: registered by `register` and not yet released, so it points to a live `T`.
    Ok(unsafe { &*ptr })
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

/// Unregisters a live handle of `kind` and drops its object: here, or, for a local object of
/// another thread (`owner` of it), on that thread at its next call ([`adopt`]).
///
/// # Safety
/// As [`get`].
pub(crate) unsafe fn free_anywhere<T: 'static>(ptr: *mut T, kind: Kind, name: &'static str, owner: impl Fn(&T) -> Owner) -> Result<(), Error> {
    // SAFETY: forwarded.
    let elsewhere = owner(unsafe { get(ptr, kind, name) }?).elsewhere();
    let object = unsafe { release(ptr, kind, name) }?;
    match elsewhere {
        Some(thread) => adopt(thread, object),
        None => drop(object),
    }
    Ok(())
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
        match self.elsewhere() {
            Some(_) => Err(Error::WrongThread(name)),
            None => Ok(()),
        }
    }

    /// The owning thread when it is not the calling one (`None`: here, or a zenoh object).
    pub(crate) fn elsewhere(self) -> Option<ThreadId> {
        self.0.filter(|id| *id != std::thread::current().id())
    }
}

/// A local object freed from another thread than its own, waiting for its thread: iceoryx2's
/// objects may be dropped only there.
struct Orphan {
    thread: ThreadId,
    /// Held only to be dropped on `thread`.
    _object: Box<dyn std::any::Any>,
}

// SAFETY: an orphan's object is only moved (never used or dropped) off its own thread: it is
// dropped by `drop_orphans` on the thread `thread` names.
unsafe impl Send for Orphan {}

/// Orphans of every thread, and how many there are (read without the lock on every call).
static ORPHANS: Mutex<Vec<Orphan>> = Mutex::new(Vec::new());
static ORPHAN_COUNT: AtomicUsize = AtomicUsize::new(0);

/// Keeps `object`, freed on this thread but belonging to `thread`, until `thread` makes its
/// next call into Lumen, which drops it there ([`drop_orphans`]). If that thread never calls
/// again, the object stays until the process ends (its memory only: what it held on the daemon
/// was closed by whoever freed it).
pub(crate) fn adopt<T: 'static>(thread: ThreadId, object: Box<T>) {
    let mut orphans = ORPHANS.lock().unwrap_or_else(PoisonError::into_inner);
    orphans.push(Orphan { thread, _object: object });
    ORPHAN_COUNT.store(orphans.len(), Ordering::SeqCst);
}

/// Drops the orphans of the calling thread (at the start of every call).
pub(crate) fn drop_orphans() {
    if ORPHAN_COUNT.load(Ordering::SeqCst) == 0 {
        return;
    }
    let here = std::thread::current().id();
    let mine: Vec<Orphan> = {
        let mut orphans = ORPHANS.lock().unwrap_or_else(PoisonError::into_inner);
        let (mine, others) = std::mem::take(&mut *orphans).into_iter().partition(|o| o.thread == here);
        *orphans = others;
        ORPHAN_COUNT.store(orphans.len(), Ordering::SeqCst);
        mine
    };
    drop(mine);
}
