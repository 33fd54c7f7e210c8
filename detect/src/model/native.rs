//! The native model format: a magic tag, a version and the body, in postcard (compact binary,
//! exact `f32` round trip).

use super::{Body, ModelError};
use serde::{Deserialize, Serialize};

const MAGIC: [u8; 4] = *b"LUMN";
const VERSION: u32 = 1;

#[derive(Serialize, Deserialize)]
struct File {
    magic: [u8; 4],
    version: u32,
    body: Body,
}

/// Serialises a body to native bytes.
pub fn save_native(body: &Body) -> Vec<u8> {
    postcard::to_stdvec(&File { magic: MAGIC, version: VERSION, body: body.clone() }).expect("serialising plain data cannot fail")
}

/// Reads a body from native bytes, checking tag, version and the body itself.
pub fn load_native(bytes: &[u8]) -> Result<Body, ModelError> {
    if bytes.len() < 4 || bytes[..4] != MAGIC {
        return Err(ModelError::Format("missing the LUMN tag".into()));
    }
    let f: File = postcard::from_bytes(bytes).map_err(|e| ModelError::Format(format!("corrupt native model: {e}")))?;
    if f.version != VERSION {
        return Err(ModelError::Format(format!("version {} (this build reads {VERSION})", f.version)));
    }
    match &f.body {
        Body::Tube(t) => t.validate()?,
        Body::Rod(r) => {
            super::Rod::new(r.points.clone(), r.radius.clone())?;
        }
    }
    Ok(f.body)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Rod;

    #[test]
    fn round_trip_and_rejects_garbage() {
        let b = Body::Rod(Rod::new(vec![[0.0, 1.0, 2.0], [3.0, 4.0, 1.490116e-8]], vec![0.5]).unwrap());
        let bytes = save_native(&b);
        assert_eq!(load_native(&bytes).unwrap(), b);
        assert!(load_native(b"LUMNgarbage").unwrap_err().to_string().contains("corrupt"));
        assert!(load_native(b"xx").unwrap_err().to_string().contains("LUMN"));
    }
}
