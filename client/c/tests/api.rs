//! The C API called from Rust as C would: statuses, messages and out-parameters on every
//! failure (bad spec, bad state, NULL arguments), and contacts on success.

use lumen_c::*;
use lumen_proto::Contact;
use std::ffi::c_char;
use std::ptr;

const SPEC: &str = r#"{"bodies":[{"name":"colon","shape":{"tube":{"rings":4,"spokes":8}}},
    {"name":"scope","shape":{"rod":{"points":3,"radius":[1.0]}}}],
    "pairs":[{"a":"scope","b":"colon","kind":"interior"}]}"#;

/// This thread's last error, as C would read it (asking the size first).
fn last_error() -> String {
    let needed = unsafe { lumen_last_error(ptr::null_mut(), 0) };
    let mut buf = vec![0u8; needed];
    assert_eq!(unsafe { lumen_last_error(buf.as_mut_ptr().cast(), buf.len()) }, needed);
    assert_eq!(buf.pop(), Some(0), "NUL-terminated");
    String::from_utf8(buf).unwrap()
}

fn new(spec: &str) -> (LumenStatus, *mut LumenDetector) {
    let mut out = ptr::dangling_mut();
    let status = unsafe { lumen_detector_new(spec.as_ptr().cast::<c_char>(), spec.len(), &mut out) };
    (status, out)
}

/// A straight tube of radius 5 along x and the rod on its axis, shifted `dy` along y.
fn state(dy: f32) -> Vec<f32> {
    let mut s = Vec::new();
    for i in 0..4 {
        s.extend([i as f32 * 10.0, 0.0, 0.0]);
        for k in 0..8 {
            let a = std::f32::consts::TAU * (k as f32 + 0.5) / 8.0;
            s.extend([0.0, 5.0 * a.cos(), 5.0 * a.sin()]);
        }
    }
    for j in 0..3 {
        s.extend([10.0 + j as f32 * 5.0, dy, 0.0]);
    }
    s
}

fn detect(d: *mut LumenDetector, state: &[f32]) -> (LumenStatus, *const Contact, usize) {
    let (mut contacts, mut count) = (ptr::dangling::<Contact>(), usize::MAX);
    let status = unsafe { lumen_detector_detect(d, state.as_ptr(), state.len(), &mut contacts, &mut count) };
    (status, contacts, count)
}

#[test]
fn a_good_scene_detects_and_reports_its_length() {
    let (status, d) = new(SPEC);
    assert_eq!(status, LumenStatus::Ok);
    let mut floats = 0;
    assert_eq!(unsafe { lumen_detector_floats(d, &mut floats) }, LumenStatus::Ok);
    assert_eq!(floats, 4 * 9 * 3 + 3 * 3);
    let (status, contacts, count) = detect(d, &state(4.5));
    assert_eq!(status, LumenStatus::Ok);
    assert_eq!(count, 2 * 4 + 1, "every sample presses the wall");
    let first = unsafe { &*contacts };
    assert!(first.depth > 0.0 && first.normal[1] > 0.99, "{first:?}");
    let (status, _, count) = detect(d, &state(0.0));
    assert_eq!((status, count), (LumenStatus::Ok, 0));
    unsafe { lumen_detector_free(d) };
}

#[test]
fn a_bad_spec_is_bad_spec_naming_the_problem() {
    let (status, d) = new(&SPEC.replace("\"points\":3", "\"points\":1"));
    assert_eq!((status, d), (LumenStatus::BadSpec, ptr::null_mut()));
    let message = last_error();
    assert!(message.contains("\"scope\"") && message.contains("1 control points"), "{message}");

    let (status, d) = new(&SPEC.replace("\"b\":\"colon\"", "\"b\":\"rectum\""));
    assert_eq!((status, d), (LumenStatus::BadSpec, ptr::null_mut()));
    assert!(last_error().contains("\"rectum\""), "{}", last_error());

    let (status, _) = new("{\"bodies\":[");
    assert_eq!(status, LumenStatus::BadSpec);
    assert!(last_error().contains("JSON"), "{}", last_error());

    let bytes = [b'{', 0xff, b'}'];
    let mut out = ptr::dangling_mut();
    assert_eq!(unsafe { lumen_detector_new(bytes.as_ptr().cast(), bytes.len(), &mut out) }, LumenStatus::BadUtf8);
    assert!(out.is_null());
}

#[test]
fn a_bad_state_is_bad_state_and_the_detector_goes_on() {
    let (_, d) = new(SPEC);
    let good = state(4.5);
    let (status, contacts, count) = detect(d, &good[..good.len() - 1]);
    assert_eq!((status, contacts, count), (LumenStatus::BadState, ptr::null(), 0));
    assert!(last_error().contains("needs exactly 117"), "{}", last_error());
    let mut bad = good.clone();
    bad[5] = f32::NAN;
    assert_eq!(detect(d, &bad).0, LumenStatus::BadState);
    assert!(last_error().contains("\"colon\""), "{}", last_error());
    let (status, _, count) = detect(d, &good);
    assert_eq!((status, count), (LumenStatus::Ok, 9));
    unsafe { lumen_detector_free(d) };
}

#[test]
fn null_arguments_are_null_argument_not_crashes() {
    let mut out = ptr::dangling_mut();
    assert_eq!(unsafe { lumen_detector_new(ptr::null(), 3, &mut out) }, LumenStatus::NullArgument);
    assert!(out.is_null());
    assert!(last_error().contains("spec_json"), "{}", last_error());
    assert_eq!(unsafe { lumen_detector_new(SPEC.as_ptr().cast(), SPEC.len(), ptr::null_mut()) }, LumenStatus::NullArgument);

    let mut floats = 7;
    assert_eq!(unsafe { lumen_detector_floats(ptr::null(), &mut floats) }, LumenStatus::NullArgument);
    assert_eq!(floats, 0);
    let (_, d) = new(SPEC);
    assert_eq!(unsafe { lumen_detector_floats(d, ptr::null_mut()) }, LumenStatus::NullArgument);

    let good = state(0.0);
    assert_eq!(detect(ptr::null_mut(), &good).0, LumenStatus::NullArgument);
    assert!(last_error().contains("detector"), "{}", last_error());
    let (mut contacts, mut count) = (ptr::null(), 0);
    assert_eq!(unsafe { lumen_detector_detect(d, ptr::null(), good.len(), &mut contacts, &mut count) }, LumenStatus::NullArgument);
    assert_eq!(unsafe { lumen_detector_detect(d, good.as_ptr(), good.len(), ptr::null_mut(), &mut count) }, LumenStatus::NullArgument);
    assert_eq!(unsafe { lumen_detector_detect(d, good.as_ptr(), good.len(), &mut contacts, ptr::null_mut()) }, LumenStatus::NullArgument);
    unsafe { lumen_detector_free(d) };
    unsafe { lumen_detector_free(ptr::null_mut()) };
}

#[test]
fn the_last_error_is_cut_safely_and_kept_per_thread() {
    let _ = new("[");
    let full = last_error();
    let mut small = [0x55u8; 8];
    let needed = unsafe { lumen_last_error(small.as_mut_ptr().cast(), small.len()) };
    assert_eq!(needed, full.len() + 1);
    assert_eq!(&small[..7], &full.as_bytes()[..7]);
    assert_eq!(small[7], 0);
    let other = std::thread::spawn(last_error).join().unwrap();
    assert_eq!(other, "", "another thread has no error yet");
}

#[test]
fn freed_foreign_and_wrong_kind_handles_are_bad_handle_not_crashes() {
    let (_, d) = new(SPEC);
    assert_eq!(unsafe { lumen_detector_free(d) }, LumenStatus::Ok);
    // Used after its free, freed twice: refused without being read.
    assert_eq!(detect(d, &state(0.0)).0, LumenStatus::BadHandle);
    assert!(last_error().contains("not a live handle"), "{}", last_error());
    assert_eq!(unsafe { lumen_detector_free(d) }, LumenStatus::BadHandle);
    // A pointer Lumen never made.
    let mut bogus = 0u64;
    assert_eq!(detect((&raw mut bogus).cast(), &state(0.0)).0, LumenStatus::BadHandle);

    // A client given where a detector or a session is wanted (a local client sends nothing
    // until a session opens, so no daemon is needed).
    let prefix = format!("lc{}_handles_\0", std::process::id());
    let mut client = ptr::null_mut();
    assert_eq!(unsafe { lumen_client_local(prefix.as_ptr().cast(), ptr::null(), &mut client) }, LumenStatus::Ok, "{}", last_error());
    assert_eq!(detect(client.cast(), &state(0.0)).0, LumenStatus::BadHandle);
    assert!(last_error().contains("Client handle, not a Detector"), "{}", last_error());
    let mut number = 0;
    assert_eq!(unsafe { lumen_session_submit(client.cast(), &mut number) }, LumenStatus::BadHandle);
    assert_eq!(unsafe { lumen_client_free(client) }, LumenStatus::Ok);
    lumen_transport::shm::remove_prefix(prefix.trim_end_matches('\0'));
    // A prefix iceoryx2 cannot take is TRANSPORT, as lumen.h says; a name that is not UTF-8 is
    // BAD_UTF8.
    let mut bad = ptr::null_mut();
    assert_eq!(unsafe { lumen_client_local(c"a/b".as_ptr(), ptr::null(), &mut bad) }, LumenStatus::Transport, "{}", last_error());
    assert!(bad.is_null());
    assert_eq!(unsafe { lumen_client_local(prefix.as_ptr().cast(), c"\xff".as_ptr(), &mut bad) }, LumenStatus::BadUtf8);
}

#[test]
fn a_local_client_is_refused_on_another_thread() {
    let prefix = format!("lc{}_thread_\0", std::process::id());
    let mut client = ptr::null_mut();
    assert_eq!(unsafe { lumen_client_local(prefix.as_ptr().cast(), ptr::null(), &mut client) }, LumenStatus::Ok, "{}", last_error());
    let address = client as usize;
    let (status, message) = std::thread::spawn(move || {
        let mut session = ptr::null_mut();
        let status = unsafe { lumen_session_open(address as *mut LumenClient, SPEC.as_ptr().cast(), SPEC.len(), &mut session) };
        assert!(session.is_null());
        (status, last_error())
    })
    .join()
    .unwrap();
    assert_eq!(status, LumenStatus::WrongThread);
    assert!(message.contains("thread that made it"), "{message}");
    // On its own thread the same call goes through to the transport: no daemon there.
    let mut session = ptr::null_mut();
    assert_eq!(unsafe { lumen_session_open(client, SPEC.as_ptr().cast(), SPEC.len(), &mut session) }, LumenStatus::NoDaemon);
    assert!(last_error().contains("lumen serve"), "{}", last_error());
    assert_eq!(unsafe { lumen_client_free(client) }, LumenStatus::Ok);
    lumen_transport::shm::remove_prefix(prefix.trim_end_matches('\0'));
}

#[test]
fn a_zenoh_client_names_a_missing_tls_file_and_a_half_identity() {
    let endpoint = "tls/127.0.0.1:9\0";
    let missing = "/nonexistent/ca.pem\0";
    let tls = LumenTls { root_ca: missing.as_ptr().cast(), certificate: ptr::null(), private_key: ptr::null() };
    let mut client = ptr::dangling_mut();
    assert_eq!(unsafe { lumen_client_zenoh(endpoint.as_ptr().cast(), &tls, ptr::null(), &mut client) }, LumenStatus::NoDaemon);
    assert!(client.is_null());
    assert!(last_error().contains("/nonexistent/ca.pem"), "{}", last_error());
    let half = LumenTls { root_ca: missing.as_ptr().cast(), certificate: missing.as_ptr().cast(), private_key: ptr::null() };
    assert_eq!(unsafe { lumen_client_zenoh(endpoint.as_ptr().cast(), &half, ptr::null(), &mut client) }, LumenStatus::NullArgument);
    assert!(last_error().contains("go together"), "{}", last_error());
}

/// Two threads calling one detector at once (forbidden): each call either runs or is refused
/// with WRONG_THREAD, never PANIC, and the detector answers correctly afterwards.
#[test]
fn two_threads_on_one_detector_are_refused_not_poisoned() {
    let (status, d) = new(SPEC);
    assert_eq!(status, LumenStatus::Ok);
    let (_, _, expected) = detect(d, &state(0.5));
    let handle = d as usize;
    let refused: usize = std::thread::scope(|s| {
        let workers: Vec<_> = (0..2)
            .map(|_| {
                s.spawn(move || {
                    let mut refused = 0;
                    for _ in 0..2000 {
                        match detect(handle as *mut LumenDetector, &state(0.5)).0 {
                            LumenStatus::Ok => {}
                            LumenStatus::WrongThread => refused += 1,
                            other => panic!("{other:?}: {}", last_error()),
                        }
                    }
                    refused
                })
            })
            .collect();
        workers.into_iter().map(|w| w.join().unwrap()).sum()
    });
    eprintln!("{refused} of 4000 calls refused while the other thread's ran");
    let (status, _, count) = detect(d, &state(0.5));
    assert_eq!((status, count), (LumenStatus::Ok, expected), "the detector goes on");
    assert_eq!(unsafe { lumen_detector_free(d) }, LumenStatus::Ok);
}
