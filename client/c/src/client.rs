//! `lumen_client_*`: a connection to the daemon (`lumen serve`), on this machine over iceoryx2
//! shared memory or across machines over zenoh, as an opaque handle.

use crate::boundary::call;
use crate::error::Error;
use crate::handles::{self, Kind, Owner};
use crate::status::LumenStatus;
use crate::text;
use lumen_client::{Client, LocalOptions, Tls};
use std::ffi::c_char;
use std::path::PathBuf;
use std::ptr;

/// A connection to the daemon (opaque): made by `lumen_client_local` or `lumen_client_zenoh`,
/// freed by `lumen_client_free`. Sessions and observers it opens live on after it is freed.
///
/// Threading: a local (iceoryx2) client, its sessions and its observers belong to the thread
/// that made the client: any other thread's call gets `LUMEN_STATUS_WRONG_THREAD`, except the
/// calls that end them (`lumen_session_close`, `lumen_observer_free`, `lumen_client_free`),
/// which any thread may make (a finalizer, `OnDestroy`, another task). Make one client per
/// thread that sends frames. Zenoh ones may be used from any thread, one call at a time per
/// handle.
pub struct LumenClient {
    pub(crate) client: Client,
    pub(crate) owner: Owner,
    /// A local client's iceoryx2 prefix as given (`None`: the environment's, or the default):
    /// a session closed from another thread is closed through a client of that thread.
    pub(crate) prefix: Option<String>,
}

/// A zenoh client's TLS material: paths of PEM files, NUL-terminated.
#[repr(C)]
pub struct LumenTls {
    /// The certificate authority that signed the daemon's certificate (required).
    pub root_ca: *const c_char,
    /// This client's certificate, for a daemon that requires client certificates (mutual
    /// TLS); NULL otherwise. Goes with `private_key`.
    pub certificate: *const c_char,
    /// The private key of `certificate`; NULL when `certificate` is.
    pub private_key: *const c_char,
}

/// Connects to the daemon on this machine over iceoryx2 shared memory.
///
/// `prefix` is iceoryx2's `global.prefix` and must be the daemon's (`lumen serve --prefix`);
/// NULL: the `LUMEN_IOX2_PREFIX` environment variable, else iceoryx2's default. `name` is
/// what `lumen status` shows for this client's sessions; NULL: the executable's name.
/// Nothing is sent yet: a missing daemon shows at `lumen_session_open`. `LUMEN_STATUS_BAD_UTF8`
/// for a `prefix` or `name` that is not UTF-8; `LUMEN_STATUS_TRANSPORT` when iceoryx2 cannot
/// start here (shared memory, permissions, an invalid prefix).
///
/// On `LUMEN_STATUS_OK`, `*out` is the new client, the caller's until `lumen_client_free`.
///
/// # Safety
/// `prefix` and `name` are NULL or NUL-terminated; `out` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn lumen_client_local(prefix: *const c_char, name: *const c_char, out: *mut *mut LumenClient) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let out = unsafe { out.as_mut() }.ok_or(Error::NullArgument("out"))?;
        *out = ptr::null_mut();
        let prefix = unsafe { text::optional(prefix, "prefix") }?.map(str::to_owned);
        let name = unsafe { text::optional(name, "name") }?.map(str::to_owned);
        let client = Client::local_with(LocalOptions { prefix: prefix.clone(), name })?;
        *out = handles::register(LumenClient { client, owner: Owner::new(true), prefix }, Kind::Client);
        Ok(())
    })
}

/// Connects to the daemon at a zenoh endpoint: `tcp/HOST:PORT`, or `tls/HOST:PORT` with
/// `tls` giving the certificate authority (and, for mutual TLS, this client's certificate and
/// key). `tls` NULL: no TLS material. `name` as in `lumen_client_local`.
///
/// On `LUMEN_STATUS_OK`, `*out` is the new client. `LUMEN_STATUS_NO_DAEMON` when the endpoint
/// cannot be reached or a TLS file does not exist (the message names it).
/// `LUMEN_STATUS_TRANSPORT` for a plain (not `tls/`) endpoint on another machine, whose daemon
/// cannot be authenticated, unless the environment has `LUMEN_ZENOH_INSECURE=1`.
///
/// # Safety
/// `endpoint` is NUL-terminated; `tls` is NULL or points to a `LumenTls` whose strings are
/// NULL or NUL-terminated; `name` is NULL or NUL-terminated; `out` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn lumen_client_zenoh(endpoint: *const c_char, tls: *const LumenTls, name: *const c_char, out: *mut *mut LumenClient) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let out = unsafe { out.as_mut() }.ok_or(Error::NullArgument("out"))?;
        *out = ptr::null_mut();
        let endpoint = unsafe { text::required(endpoint, "endpoint") }?;
        let name = unsafe { text::optional(name, "name") }?;
        let client = match unsafe { tls.as_ref() } {
            None => Client::zenoh(endpoint)?,
            Some(tls) => {
                let path = |p, name| unsafe { text::optional(p, name) }.map(|p| p.map(PathBuf::from));
                let root_ca = path(tls.root_ca, "tls.root_ca")?.ok_or(Error::NullArgument("tls.root_ca"))?;
                let identity = match (path(tls.certificate, "tls.certificate")?, path(tls.private_key, "tls.private_key")?) {
                    (Some(c), Some(k)) => Some((c, k)),
                    (None, None) => None,
                    _ => return Err(Error::HalfIdentity),
                };
                Client::zenoh_with_tls(endpoint, &Tls { root_ca, identity })?
            }
        };
        let client = match name {
            Some(n) => client.with_name(n),
            None => client,
        };
        *out = handles::register(LumenClient { client, owner: Owner::new(false), prefix: None }, Kind::Client);
        Ok(())
    })
}

/// Frees a client (its sessions and observers stay open). NULL is a no-op. Any thread may free
/// it: a local client freed off its own thread is dropped by that thread at its next call into
/// Lumen.
///
/// # Safety
/// No call on `client` runs meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_client_free(client: *mut LumenClient) -> LumenStatus {
    if client.is_null() {
        return LumenStatus::Ok;
    }
    call(|| {
        // SAFETY: no call on it runs meanwhile (the caller's contract).
        unsafe { handles::free_anywhere(client, Kind::Client, "client", |c| c.owner) }
    })
}
