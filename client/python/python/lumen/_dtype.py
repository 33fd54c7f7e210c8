"""The NumPy dtype of a contact, built from the Rust record's own field offsets."""

import numpy as np

from . import _lumen

CONTACT_DTYPE = np.dtype(
    {
        "names": [name for name, _, _ in _lumen.contact_fields()],
        "formats": [fmt for _, fmt, _ in _lumen.contact_fields()],
        "offsets": [offset for _, _, offset in _lumen.contact_fields()],
        "itemsize": _lumen.CONTACT_BYTES,
    }
)
"""One contact: the 88-byte ``lumen_proto::Contact`` (proto/README.md, section 3)."""

if CONTACT_DTYPE.itemsize != 88:  # pragma: no cover - a build of mismatched halves
    raise ImportError(f"lumen: the contact record is {CONTACT_DTYPE.itemsize} bytes, expected 88")
