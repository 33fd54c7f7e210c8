//! The native model format: a magic tag, a version and the body, in postcard (compact binary,
//! exact `f32` round trip). Version 2 adds what the import that wrote the body measured
//! ([`ImportInfo`], absent for a body that was not imported); version 1 files (the body alone)
//! are still read.

use super::{Body, ImportInfo, ModelError};
use serde::{Deserialize, Serialize};

const MAGIC: [u8; 4] = *b"LUMN";
const VERSION: u32 = 2;

#[derive(Serialize)]
struct FileOut<'a> {
    magic: [u8; 4],
    version: u32,
    body: &'a Body,
    import: Option<&'a ImportInfo>,
}

#[derive(Deserialize)]
struct Header {
    magic: [u8; 4],
    version: u32,
}

#[derive(Deserialize)]
struct V1 {
    #[allow(dead_code)]
    header: Header,
    body: Body,
}

#[derive(Deserialize)]
struct V2 {
    #[allow(dead_code)]
    header: Header,
    body: Body,
    import: Option<ImportInfo>,
}

/// Serialises a body to native bytes.
pub fn save_native(body: &Body) -> Vec<u8> {
    save_native_with(body, None)
}

/// Serialises a body and what its import measured to native bytes.
pub fn save_native_with(body: &Body, import: Option<&ImportInfo>) -> Vec<u8> {
    postcard::to_stdvec(&FileOut { magic: MAGIC, version: VERSION, body, import }).expect("serialising plain data cannot fail")
}

/// Reads a body from native bytes, checking tag, version and the body itself.
pub fn load_native(bytes: &[u8]) -> Result<Body, ModelError> {
    load_native_with(bytes).map(|(b, _)| b)
}

/// Reads a body and what its import measured (`None` for a body that was not imported, or a
/// version 1 file) from native bytes, checking tag, version and the body itself.
pub fn load_native_with(bytes: &[u8]) -> Result<(Body, Option<ImportInfo>), ModelError> {
    if bytes.len() < 4 || bytes[..4] != MAGIC {
        return Err(ModelError::Format("missing the LUMN tag".into()));
    }
    let corrupt = |e: postcard::Error| ModelError::Format(format!("corrupt native model: {e}"));
    let (h, _): (Header, _) = postcard::take_from_bytes(bytes).map_err(corrupt)?;
    debug_assert_eq!(h.magic, MAGIC);
    let (body, import) = match h.version {
        1 => (postcard::from_bytes::<V1>(bytes).map_err(corrupt)?.body, None),
        2 => {
            let f: V2 = postcard::from_bytes(bytes).map_err(corrupt)?;
            (f.body, f.import)
        }
        // A later version that reads as this one's layout is one; anything else is corrupt.
        v => {
            postcard::from_bytes::<V2>(bytes).map_err(corrupt)?;
            return Err(ModelError::Format(format!("version {v} (this build reads 1 to {VERSION})")));
        }
    };
    match &body {
        Body::Tube(t) => t.validate()?,
        Body::Rod(r) => {
            super::Rod::new(r.points.clone(), r.radius.clone())?;
        }
    }
    Ok((body, import))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Rod, Tube};

    #[test]
    fn round_trip_and_rejects_garbage() {
        let b = Body::Rod(Rod::new(vec![[0.0, 1.0, 2.0], [3.0, 4.0, 1.490116e-8]], vec![0.5]).unwrap());
        let bytes = save_native(&b);
        assert_eq!(load_native(&bytes).unwrap(), b);
        assert!(load_native(b"LUMNgarbage").unwrap_err().to_string().contains("corrupt"));
        assert!(load_native(b"xx").unwrap_err().to_string().contains("LUMN"));
    }

    #[test]
    fn the_import_travels_with_the_body_and_version_1_files_still_read() {
        let t = Body::Tube(Tube::new(vec![[0.0; 3], [0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, -1.0, 0.0]].repeat(2), 3).unwrap());
        let info = ImportInfo { fidelity_mm: [0.01, 0.35, 7.0], kept_p99_mm: 0.27, samples: 12, report: "Imported 2 rings".into() };
        let bytes = save_native_with(&t, Some(&info));
        assert_eq!(load_native_with(&bytes).unwrap(), (t.clone(), Some(info)));
        assert_eq!(load_native(&bytes).unwrap(), t);
        assert_eq!(load_native_with(&save_native(&t)).unwrap(), (t.clone(), None));
        // Version 1: the tag, the version and the body, nothing after.
        #[derive(Serialize)]
        struct V1Out<'a>(&'a [u8; 4], u32, &'a Body);
        let v1 = postcard::to_stdvec(&V1Out(&MAGIC, 1, &t)).unwrap();
        assert_eq!(load_native_with(&v1).unwrap(), (t.clone(), None));
        #[derive(Serialize)]
        struct V9Out<'a>(&'a [u8; 4], u32, &'a Body, Option<&'a ImportInfo>);
        let v9 = postcard::to_stdvec(&V9Out(&MAGIC, 9, &t, None)).unwrap();
        assert!(load_native(&v9).unwrap_err().to_string().contains("version 9 (this build reads 1 to 2)"));
    }
}
