//! The scene channel against Foxglove's own schema, read back from a recording.
//!
//! Validation is a small checker walking the stored schema's own keywords (`type`,
//! `properties`, `required`, `items`, `oneOf`, `const`, `minimum`, `maximum`; any other one
//! fails the test) rather than the `jsonschema` crate: that crate would add a dozen crates (regex
//! engines, URL and IDN handling) to the lock file and the shared build for the 12 keywords this
//! schema uses.

use super::*;
use crate::recording::{Missed, Recording, Writer, WriterOptions, SCENE_TOPIC};
use lumen_proto::wire::{ContactsHeader, FrameHeader};
use lumen_proto::{BodySpec, ContactKind, PairSpec};
use serde_json::Value;
use std::path::PathBuf;

/// Keywords that only annotate (they constrain nothing).
const ANNOTATIONS: [&str; 4] = ["title", "description", "$comment", "contentEncoding"];

/// Checks `v` against `schema` (a subset of JSON Schema: the keywords the Foxglove schemas use);
/// the error names the path of the first value that fails.
fn validate(schema: &Value, v: &Value, at: &str) -> Result<(), String> {
    let s = schema.as_object().ok_or_else(|| format!("{at}: the schema is not an object"))?;
    for key in s.keys() {
        let known = ["type", "properties", "required", "items", "oneOf", "const", "minimum", "maximum"];
        assert!(known.contains(&key.as_str()) || ANNOTATIONS.contains(&key.as_str()), "the checker does not know the schema keyword {key:?} (at {at})");
    }
    if let Some(t) = s.get("type") {
        let types: Vec<&str> = match t {
            Value::String(t) => vec![t.as_str()],
            Value::Array(ts) => ts.iter().filter_map(Value::as_str).collect(),
            _ => return Err(format!("{at}: bad type keyword {t}")),
        };
        let is = |t: &str| match t {
            "object" => v.is_object(),
            "array" => v.is_array(),
            "string" => v.is_string(),
            "boolean" => v.is_boolean(),
            "null" => v.is_null(),
            "number" => v.is_number(),
            "integer" => v.is_u64() || v.is_i64() || v.as_f64().is_some_and(|f| f.fract() == 0.0),
            other => panic!("unknown type {other:?} at {at}"),
        };
        if !types.iter().any(|t| is(t)) {
            return Err(format!("{at}: {v} is not of type {t}"));
        }
    }
    if let Some(c) = s.get("const") {
        let same = match (c.as_f64(), v.as_f64()) {
            (Some(a), Some(b)) => a == b,
            _ => c == v,
        };
        if !same {
            return Err(format!("{at}: {v} is not {c}"));
        }
    }
    if let (Some(min), Some(x)) = (s.get("minimum").and_then(Value::as_f64), v.as_f64()) {
        if x < min {
            return Err(format!("{at}: {x} below the minimum {min}"));
        }
    }
    if let (Some(max), Some(x)) = (s.get("maximum").and_then(Value::as_f64), v.as_f64()) {
        if x > max {
            return Err(format!("{at}: {x} above the maximum {max}"));
        }
    }
    if let (Some(req), Some(o)) = (s.get("required").and_then(Value::as_array), v.as_object()) {
        for r in req {
            let r = r.as_str().expect("required names are strings");
            if !o.contains_key(r) {
                return Err(format!("{at}: missing required {r:?}"));
            }
        }
    }
    if let (Some(props), Some(o)) = (s.get("properties").and_then(Value::as_object), v.as_object()) {
        for (k, sub) in props {
            if let Some(x) = o.get(k) {
                validate(sub, x, &format!("{at}.{k}"))?;
            }
        }
    }
    if let (Some(items), Some(a)) = (s.get("items"), v.as_array()) {
        for (i, x) in a.iter().enumerate() {
            validate(items, x, &format!("{at}[{i}]"))?;
        }
    }
    if let Some(one) = s.get("oneOf").and_then(Value::as_array) {
        let matching = one.iter().filter(|sub| validate(sub, v, at).is_ok()).count();
        if matching != 1 {
            return Err(format!("{at}: {v} matches {matching} of oneOf, not exactly one"));
        }
    }
    Ok(())
}

fn schema() -> Value {
    serde_json::from_str(SCENE_UPDATE_SCHEMA).expect("the stored schema is JSON")
}

const RINGS: usize = 6;
const SPOKES: usize = 8;
const POINTS: usize = 5;
const RADIUS: f32 = 1.5;

fn spec() -> SceneSpec {
    SceneSpec::new(
        vec![BodySpec { name: "colon".into(), shape: Shape::Tube { rings: RINGS, spokes: SPOKES } }, BodySpec { name: "scope".into(), shape: Shape::Rod { points: POINTS, radius: vec![RADIUS] } }],
        vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }],
    )
}

/// Ring `i`'s control point and spoke `k`'s radial vector of frame `f`.
fn ring(i: usize, f: usize) -> [f32; 3] {
    [i as f32 * 10.0, 0.1 * f as f32, 0.0]
}
fn spoke(k: usize) -> [f32; 3] {
    let a = k as f32 / SPOKES as f32 * std::f32::consts::TAU;
    [0.0, 5.0 * a.cos(), 5.0 * a.sin()]
}
fn scope_point(j: usize, f: usize) -> [f32; 3] {
    [j as f32 * 4.0 + f as f32, 0.5, -0.25]
}

fn state(f: usize) -> Vec<f32> {
    let mut s = Vec::new();
    for i in 0..RINGS {
        s.extend_from_slice(&ring(i, f));
        for k in 0..SPOKES {
            s.extend_from_slice(&spoke(k));
        }
    }
    for j in 0..POINTS {
        s.extend_from_slice(&scope_point(j, f));
    }
    assert_eq!(s.len(), spec().bodies.iter().map(BodySpec::floats).sum::<usize>());
    s
}

/// Frame `f`'s contacts: `f % 4` of them, depths 0.5 apart, the third one outside the wall.
fn contacts(f: usize) -> Vec<Contact> {
    (0..f % 4)
        .map(|i| Contact {
            body_a: 1,
            body_b: 0,
            sample: i as u32,
            flags: if i == 2 { FLAG_OUTSIDE } else { 0 },
            point_b: [f as f32, 1.0 + i as f32, 2.0],
            normal: [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.6, 0.0, 0.8]][i],
            depth: 0.5 + 1.5 * i as f32,
            ..Contact::default()
        })
        .collect()
}

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("lumen_foxglove_{}_{name}", std::process::id()))
}

/// Frames 250 ms apart from 1 s: the colon at 1, 2, 3 s of log time (frames 0, 4, 8, 12).
const FRAMES: usize = 14;
const STEP_NS: u64 = 250_000_000;
fn log_time(f: usize) -> u64 {
    1_000_000_000 + f as u64 * STEP_NS
}

fn write(path: &std::path::Path, options: WriterOptions) -> crate::recording::Written {
    let mut w = Writer::create_with(path, &spec(), 7, "test", options).unwrap();
    for f in 0..FRAMES {
        let s = state(f);
        let h = FrameHeader::new(7, f as u64, log_time(f), s.len(), 2);
        w.frame(&h, &s, 5).unwrap();
        let c = contacts(f);
        let mut reply = ContactsHeader::reply_to(&h);
        reply.count = c.len() as u32;
        w.contacts(&reply, &c, 6).unwrap();
    }
    w.finish(Missed::default()).unwrap()
}

fn entity<'a>(update: &'a Value, id: &str) -> Option<&'a Value> {
    update["entities"].as_array().unwrap().iter().find(|e| e["id"] == id)
}

fn xyz(p: &Value) -> [f32; 3] {
    [p["x"].as_f64().unwrap() as f32, p["y"].as_f64().unwrap() as f32, p["z"].as_f64().unwrap() as f32]
}

/// `v` rotated by the unit quaternion `q`.
fn rotate(q: &Value, v: [f32; 3]) -> [f32; 3] {
    let (x, y, z, w) = (q["x"].as_f64().unwrap(), q["y"].as_f64().unwrap(), q["z"].as_f64().unwrap(), q["w"].as_f64().unwrap());
    let v = [v[0] as f64, v[1] as f64, v[2] as f64];
    // t = 2 q.xyz x v; v' = v + w t + q.xyz x t
    let t = [2.0 * (y * v[2] - z * v[1]), 2.0 * (z * v[0] - x * v[2]), 2.0 * (x * v[1] - y * v[0])];
    let c = [y * t[2] - z * t[1], z * t[0] - x * t[2], x * t[1] - y * t[0]];
    [(v[0] + w * t[0] + c[0]) as f32, (v[1] + w * t[1] + c[1]) as f32, (v[2] + w * t[2] + c[2]) as f32]
}

fn close(a: [f32; 3], b: [f32; 3]) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() < 1e-5)
}

#[test]
fn the_checker_rejects_what_the_schema_forbids() {
    let schema = schema();
    let mut out = Vec::new();
    let mut w = SceneWriter::new(&spec());
    w.frame(log_time(0), &state(0), &mut out).unwrap();
    let good: Value = serde_json::from_slice(&out).unwrap();
    validate(&schema, &good, "$").unwrap();
    // A missing required field, a wrong type, a NaN (serde_json's null), a bad line type,
    // a negative time: each is refused.
    let mut bad = good.clone();
    bad["entities"][0].as_object_mut().unwrap().remove("lifetime");
    assert!(validate(&schema, &bad, "$").unwrap_err().contains("lifetime"));
    let mut bad = good.clone();
    bad["entities"][0]["frame_id"] = Value::from(3);
    assert!(validate(&schema, &bad, "$").is_err());
    let mut bad = good.clone();
    bad["entities"][1]["lines"][0]["points"][0]["x"] = Value::Null;
    assert!(validate(&schema, &bad, "$").unwrap_err().contains("points[0].x"));
    let mut bad = good.clone();
    bad["entities"][1]["lines"][0]["type"] = Value::from(7);
    assert!(validate(&schema, &bad, "$").unwrap_err().contains("oneOf"));
    let mut bad = good;
    bad["entities"][0]["timestamp"]["nsec"] = Value::from(1_000_000_000u64);
    assert!(validate(&schema, &bad, "$").unwrap_err().contains("maximum"));
}

#[test]
fn a_recording_holds_a_scene_channel_that_foxglove_reads() {
    let path = temp("scene.mcap");
    let written = write(&path, WriterOptions::default());
    let schema = schema();
    let bytes = std::fs::read(&path).unwrap();

    let (mut frame_updates, mut reply_updates) = (Vec::new(), Vec::new());
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic != SCENE_TOPIC {
            continue;
        }
        assert_eq!(m.channel.message_encoding, "json");
        let s = m.channel.schema.as_ref().expect("a schema");
        assert_eq!((s.name.as_str(), s.encoding.as_str()), ("foxglove.SceneUpdate", "jsonschema"));
        assert_eq!(&s.data[..], SCENE_UPDATE_SCHEMA.as_bytes(), "the stored Foxglove schema, unchanged");
        let text = std::str::from_utf8(&m.data).unwrap();
        let update: Value = serde_json::from_str(text).unwrap();
        validate(&schema, &update, "$").unwrap_or_else(|e| panic!("message {}: {e}", m.sequence));
        for e in update["entities"].as_array().unwrap() {
            assert_eq!(e["frame_id"], FRAME_ID);
            assert_eq!((e["lifetime"]["sec"].as_u64(), e["lifetime"]["nsec"].as_u64()), (Some(0), Some(0)), "lifetime 0: until replaced");
            let ns = e["timestamp"]["sec"].as_u64().unwrap() * 1_000_000_000 + e["timestamp"]["nsec"].as_u64().unwrap();
            assert_eq!(ns, m.log_time, "the entity's timestamp is the message's log time");
        }
        if entity(&update, CONTACTS_ID).is_some() {
            reply_updates.push((m.log_time, update));
        } else {
            frame_updates.push((m.log_time, update));
        }
    }
    assert_eq!((frame_updates.len(), reply_updates.len()), (FRAMES, FRAMES));
    assert_eq!(written.scene, 2 * FRAMES as u64);

    for (f, (t, update)) in frame_updates.iter().enumerate() {
        assert_eq!(*t, log_time(f));
        // The scope: a line strip through its points, as thick as it is wide.
        let line = &entity(update, "rod/scope").expect("the scope every frame")["lines"][0];
        assert_eq!((line["type"].as_u64(), line["scale_invariant"].as_bool()), (Some(0), Some(false)));
        assert_eq!(line["thickness"].as_f64(), Some(2.0 * RADIUS as f64));
        let pts = line["points"].as_array().unwrap();
        assert_eq!(pts.len(), POINTS);
        for (j, p) in pts.iter().enumerate() {
            assert_eq!(xyz(p), scope_point(j, f));
        }
        // The colon: on the first frame and once per second of log time (frames 0, 4, 8, 12).
        let colon = entity(update, "tube/colon");
        assert_eq!(colon.is_some(), f % 4 == 0, "frame {f}");
        if let Some(colon) = colon {
            let tri = &colon["triangles"][0];
            let (pts, idx) = (tri["points"].as_array().unwrap(), tri["indices"].as_array().unwrap());
            let rows = RINGS; // one row per ring at WALL_STEPS = 1
            assert_eq!(pts.len(), rows * SPOKES);
            assert_eq!(idx.len(), 2 * (rows - 1) * SPOKES * 3, "two triangles per quad, around");
            assert!(idx.iter().all(|i| (i.as_u64().unwrap() as usize) < pts.len()));
            assert!(tri["color"]["a"].as_f64().unwrap() < 1.0, "see-through");
            for (n, p) in pts.iter().enumerate() {
                let (c, v) = (ring(n / SPOKES, f), spoke(n % SPOKES));
                // Rounded to 1e-4: the largest coordinate is 50 (DRAWN_PRECISION).
                let (got, want) = (xyz(p), [c[0] + v[0], c[1] + v[1], c[2] + v[2]]);
                assert!((0..3).all(|i| (got[i] - want[i]).abs() <= 0.5e-4 + 1e-6), "wall point {n}: {got:?} for {want:?}");
            }
            // The quad (0, last spoke) closes the tube: its triangles join spoke 7 and spoke 0.
            let last: Vec<u64> = idx[(SPOKES - 1) * 6..SPOKES * 6].iter().map(|i| i.as_u64().unwrap()).collect();
            assert_eq!(last, [7, 15, 8, 7, 8, 0]);
        }
    }

    for (f, (t, update)) in reply_updates.iter().enumerate() {
        assert_eq!(*t, log_time(f));
        let arrows = entity(update, CONTACTS_ID).unwrap()["arrows"].as_array().unwrap();
        let sent = contacts(f);
        assert_eq!(arrows.len(), sent.len(), "one arrow per contact (frame {f})");
        for (a, c) in arrows.iter().zip(&sent) {
            assert_eq!(xyz(&a["pose"]["position"]), c.point_b, "at the wall point");
            assert!(close(rotate(&a["pose"]["orientation"], [1.0, 0.0, 0.0]), c.normal), "along the normal: {a}");
            let color = [&a["color"]["r"], &a["color"]["g"], &a["color"]["b"]].map(|v| v.as_f64().unwrap() as f32);
            let want = if c.flags & FLAG_OUTSIDE != 0 { [1.0, 0.0, 1.0] } else { [1.0, 1.0 - (c.depth / RED_DEPTH).min(1.0), 0.0] };
            assert_eq!(color, want, "depth {}", c.depth);
        }
    }

    // The project's reader and a replay's frames still read the file; the channel is skipped.
    let rec = Recording::open(&path).unwrap();
    assert_eq!((rec.frames, rec.replies.len()), (FRAMES as u64, FRAMES));
    let frames: Vec<_> = rec.frames().unwrap().collect::<Result<_, _>>().unwrap();
    assert_eq!(frames.len(), FRAMES);
    assert_eq!(frames[9].state, state(9));
    let _ = std::fs::remove_file(&path);
}

#[test]
fn without_the_scene_there_is_no_channel() {
    let path = temp("noscene.mcap");
    let written = write(&path, WriterOptions { scene: false });
    assert_eq!(written.scene, 0);
    let bytes = std::fs::read(&path).unwrap();
    let summary = mcap::read::Summary::read(&bytes).unwrap().unwrap();
    assert!(summary.channels.values().all(|c| c.topic != SCENE_TOPIC));
    assert!(summary.schemas.values().all(|s| s.name != SCENE_UPDATE));
    assert_eq!(Recording::open(&path).unwrap().frames, FRAMES as u64);
    let _ = std::fs::remove_file(&path);
}

#[test]
fn the_colon_rate_follows_log_time() {
    let mut w = SceneWriter::new(&spec());
    let mut out = Vec::new();
    let s = state(0);
    let mut sent = |t: u64| {
        out.clear();
        w.frame(t, &s, &mut out).unwrap()
    };
    // First frame; 900 ms later not yet; at 1 s; a clock that went back (a restarted client).
    assert!(sent(5_000_000_000));
    assert!(!sent(5_900_000_000));
    assert!(sent(6_000_000_000));
    assert!(!sent(6_500_000_000));
    assert!(sent(10));
    assert!(!sent(500_000_010));
    // A state of the wrong length has no update at all.
    out.clear();
    assert_eq!(w.frame(30, &s[1..], &mut out), None);
    assert!(out.is_empty());
}

#[test]
fn non_finite_numbers_are_never_written() {
    let schema = schema();
    let mut w = SceneWriter::new(&spec());
    let mut out = Vec::new();
    let mut s = state(0);
    let tube_floats = RINGS * (SPOKES + 1) * 3;
    s[4] = f32::NAN; // a radial vector of ring 0
    s[tube_floats + 1] = f32::INFINITY; // the scope's first point's y
    s[tube_floats + 5] = f32::NEG_INFINITY;
    assert_eq!(w.frame(log_time(0), &s, &mut out), Some(true));
    let text = std::str::from_utf8(&out).unwrap().to_owned();
    let update: Value = serde_json::from_str(&text).unwrap();
    validate(&schema, &update, "$").unwrap();
    assert!(!text.contains("null") && !text.contains("NaN") && !text.contains("inf"), "{text}");
    let pts = entity(&update, "rod/scope").unwrap()["lines"][0]["points"].as_array().unwrap();
    assert_eq!(xyz(&pts[0]), [0.0, 0.0, -0.25], "non-finite written 0");
    assert_eq!(xyz(&pts[1]), [4.0, 0.5, 0.0]);
    assert_eq!(entity(&update, "tube/colon").unwrap()["triangles"][0]["points"].as_array().unwrap().len(), RINGS * SPOKES, "the grid keeps its points");

    // Contacts: one with a NaN point, one with an infinite normal, one with a zero normal, one
    // with a NaN depth (drawn as depth 0), one good: three are skipped.
    let good = Contact { body_a: 1, point_b: [1.0, 2.0, 3.0], normal: [0.0, 0.0, -1.0], depth: 3.0, ..Contact::default() };
    let cs =
        [Contact { point_b: [f32::NAN, 0.0, 0.0], ..good }, Contact { normal: [f32::INFINITY, 0.0, 0.0], ..good }, Contact { normal: [0.0; 3], ..good }, Contact { depth: f32::NAN, ..good }, good];
    out.clear();
    w.contacts(log_time(0), &cs, &mut out);
    let text = std::str::from_utf8(&out).unwrap().to_owned();
    let update: Value = serde_json::from_str(&text).unwrap();
    validate(&schema, &update, "$").unwrap();
    assert!(!text.contains("null"), "{text}");
    let arrows = entity(&update, CONTACTS_ID).unwrap()["arrows"].as_array().unwrap();
    assert_eq!(arrows.len(), 2);
    assert_eq!(arrows[0]["color"]["g"].as_f64(), Some(1.0), "NaN depth: yellow");
    assert_eq!(arrows[1]["color"]["g"].as_f64(), Some(0.0), "3 mm: red");
    assert!(close(rotate(&arrows[1]["pose"]["orientation"], [1.0, 0.0, 0.0]), [0.0, 0.0, -1.0]));
    // No contacts: the entity, empty, replaces the last reply's arrows.
    out.clear();
    w.contacts(log_time(1), &[], &mut out);
    let update: Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(entity(&update, CONTACTS_ID).unwrap()["arrows"].as_array().unwrap().len(), 0);
}

/// The colonoscopy's real size: one colon update, its bytes and time (printed with
/// `--nocapture`), and that it validates.
#[test]
fn a_colon_sized_update() {
    let (spec, states) = lumen_scene::frames::generated(2);
    let mut w = SceneWriter::new(&spec);
    let mut out = Vec::new();
    let start = std::time::Instant::now();
    assert_eq!(w.frame(1, &states[0], &mut out), Some(true));
    let colon = (out.len(), start.elapsed());
    let update: Value = serde_json::from_slice(&out).unwrap();
    validate(&schema(), &update, "$").unwrap();
    let (rings, spokes) = match spec.bodies[0].shape {
        Shape::Tube { rings, spokes } => (rings, spokes),
        _ => unreachable!(),
    };
    // Blocks of 16 rows of quads (the last of 1,249 has 1), each with its last row of points
    // again as the next one's first, and the same indices in every whole block.
    let blocks = entity(&update, "tube/colon").unwrap()["triangles"].as_array().unwrap().clone();
    assert_eq!(blocks.len(), (rings - 1).div_ceil(WALL_BLOCK_ROWS));
    let mut points: Vec<[f32; 3]> = Vec::new();
    for (b, tri) in blocks.iter().enumerate() {
        let (pts, idx) = (tri["points"].as_array().unwrap(), tri["indices"].as_array().unwrap());
        let quads = WALL_BLOCK_ROWS.min(rings - 1 - b * WALL_BLOCK_ROWS);
        assert_eq!((pts.len(), idx.len()), ((quads + 1) * spokes, 6 * quads * spokes), "block {b}");
        if quads == WALL_BLOCK_ROWS {
            assert_eq!(idx, blocks[0]["indices"].as_array().unwrap(), "block {b}");
        }
        if let Some(last) = points.last() {
            assert_eq!(xyz(&pts[spokes - 1]), *last, "block {b} starts on the row the last ended with");
        }
        points.truncate(points.len().saturating_sub(spokes));
        points.extend(pts.iter().map(xyz));
    }
    assert_eq!(points.len(), rings * spokes);
    // Drawn to 1 um (its coordinates reach 100 mm and more): no number has more than three
    // decimals, and each is the state's within half of that.
    let text = std::str::from_utf8(&out).unwrap();
    let pts = text.split("\"points\":[").nth(1).unwrap().split(']').next().unwrap();
    assert!(pts.split([',', ':', '}']).filter_map(|t| t.split_once('.')).all(|(_, decimals)| decimals.len() <= 3), "{}", &pts[..200]);
    let mut wall = Vec::new();
    lumen_detect::wall::WallGrid { steps: WALL_STEPS, alpha: spec.alpha }.append(&states[0][..rings * (spokes + 1) * 3], rings, spokes, 0..rings - 1, &mut wall);
    assert_eq!(wall.len(), points.len());
    for (got, want) in points.iter().zip(&wall) {
        assert!((0..3).all(|i| (got[i] - want[i]).abs() <= 0.5e-3 + 1e-4), "{got:?} drawn for {want:?}");
    }
    out.clear();
    let start = std::time::Instant::now();
    assert_eq!(w.frame(1 + SCENE_EVERY_NS, &states[1], &mut out), Some(false));
    println!("colon {rings} x {spokes}: {} bytes in {:?}; a frame without it: {} bytes in {:?}", colon.0, colon.1, out.len(), start.elapsed());
}

#[test]
fn an_unpaced_session_gets_the_scene_at_a_display_rate() {
    // 100 frames 1 ms apart: the scope and the contacts at 0, 17, 34, 51, 68 and 85 ms (each at
    // least 1/60 s after the last), the colon on the first; every frame and reply still recorded.
    let path = temp("rate.mcap");
    let mut w = Writer::create_with(&path, &spec(), 7, "test", WriterOptions::default()).unwrap();
    for f in 0..100usize {
        let s = state(f % FRAMES);
        let h = FrameHeader::new(7, f as u64, 1_000_000_000 + f as u64 * 1_000_000, s.len(), 2);
        w.frame(&h, &s, 5).unwrap();
        let c = contacts(f % FRAMES);
        let mut reply = ContactsHeader::reply_to(&h);
        reply.count = c.len() as u32;
        w.contacts(&reply, &c, 6).unwrap();
    }
    let written = w.finish(Missed::default()).unwrap();
    assert_eq!((written.frames, written.replies, written.scene), (100, 100, 12));
    let bytes = std::fs::read(&path).unwrap();
    let (mut scope, mut arrows, mut colon) = (Vec::new(), Vec::new(), 0);
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic != SCENE_TOPIC {
            continue;
        }
        let update: Value = serde_json::from_slice(&m.data).unwrap();
        let ms = (m.log_time - 1_000_000_000) / 1_000_000;
        if entity(&update, CONTACTS_ID).is_some() {
            arrows.push(ms);
        } else {
            scope.push(ms);
            colon += entity(&update, "tube/colon").is_some() as usize;
        }
    }
    assert_eq!(scope, [0, 17, 34, 51, 68, 85]);
    assert_eq!(arrows, scope, "the contacts of the frames the scope was shown at");
    assert_eq!(colon, 1);
    let _ = std::fs::remove_file(&path);
}
