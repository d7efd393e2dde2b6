#!/usr/bin/env python3
"""Read a soig output's `export/tdm/truth.tdm` with an independent CCSDS reader (ccsds-ndm,
which maps the KVN onto the CCSDS NDM/XML 2.0 schema's types: it refuses an unknown
REFERENCE_FRAME, ANGLE_TYPE or TIME_SYSTEM) and compare every angle and magnitude with the
truth sidecars.

Run: pip install ccsds-ndm==3.1.1; python tests/reference/tdm_reader.py OUT
(as run for issue #45: a venv with ccsds-ndm 3.1.1 on the output of
`soig run campaigns/quickstart.toml --set images=6 --set 'stages=["render"]' --set artifacts.tdm=true`).
Prints the segments read and the largest differences from the truth.
"""
import json
import sys
from pathlib import Path

from ccsds_ndm.ndm_io import NdmIo

out = Path(sys.argv[1])
tdm = NdmIo().from_path(str(out / "export/tdm/truth.tdm"))
assert type(tdm).__name__ == "Tdm" and str(tdm.version) == "2.0", tdm.version
truths = [json.loads(p.read_text()) for p in sorted((out / "truth").glob("img_*.json"))]
truths = [t for t in truths if "ephemeris" in t and "objects" not in t]
segments = tdm.body.segment
assert len(segments) == len(truths), (len(segments), len(truths))
worst_angle = worst_mag = 0.0
for seg, t in zip(segments, truths):
    m = seg.metadata
    assert m.angle_type.value == "RADEC" and m.reference_frame.value == "ICRF", m
    assert str(getattr(m.time_system, "value", m.time_system)) == "UTC" and m.participant_2.endswith(f"(NORAD {t['norad']})")
    e = t["ephemeris"]
    want = [e["debris_radec_start_deg"], e["debris_radec_mid_deg"], e["debris_radec_end_deg"]]
    ra = [o.angle_1.value for o in seg.data.observation if o.angle_1 is not None]
    dec = [o.angle_2.value for o in seg.data.observation if o.angle_2 is not None]
    mag = [o.mag for o in seg.data.observation if o.mag is not None]
    assert len(ra) == len(dec) == 3 and len(mag) == 1
    for (r, d), w in zip(zip(ra, dec), want):
        worst_angle = max(worst_angle, abs(float(r) - w[0]), abs(float(d) - w[1]))
    worst_mag = max(worst_mag, abs(float(mag[0]) - t["magnitude"]))
# Written with 10 decimals of a degree and 6 of a magnitude.
assert worst_angle <= 5.1e-11 and worst_mag <= 5.1e-7, (worst_angle, worst_mag)
print(f"tdm_reader: {len(segments)} segments read by ccsds-ndm; angles within {worst_angle:.1e} deg "
      f"({worst_angle * 3.6e6:.1e} mas), magnitudes within {worst_mag:.1e} of the truth")
