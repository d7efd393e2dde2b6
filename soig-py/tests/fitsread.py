"""A minimal reader of the single-HDU FITS images soig writes (primary HDU, BITPIX -32 or
32, two axes, no scaling), so the tests check soig's files with code that is not soig's."""

import numpy as np


def read(path):
    """(header dict, pixels as a (NAXIS2, NAXIS1) array in native byte order)."""
    raw = open(path, "rb").read()
    header, pos = {}, 0
    while True:
        card = raw[pos : pos + 80].decode("ascii")
        pos += 80
        key = card[:8].strip()
        if key == "END":
            break
        if card[8:10] != "= ":
            continue
        value = card[10:]
        if value.lstrip().startswith("'"):
            s = value.lstrip()[1:]
            # A quoted string; '' is a quote inside it.
            text, i = "", 0
            while i < len(s):
                if s[i] == "'":
                    if s[i + 1 : i + 2] == "'":
                        text += "'"
                        i += 2
                        continue
                    break
                text += s[i]
                i += 1
            header[key] = text.rstrip()
        else:
            v = value.split("/")[0].strip()
            if v in ("T", "F"):
                header[key] = v == "T"
            else:
                try:
                    header[key] = int(v)
                except ValueError:
                    header[key] = float(v.replace("D", "E"))
    pos = -(-pos // 2880) * 2880  # the data start at the next 2880-byte block
    dtype = {-32: ">f4", 32: ">i4"}[header["BITPIX"]]
    n1, n2 = header["NAXIS1"], header["NAXIS2"]
    data = np.frombuffer(raw, dtype=dtype, count=n1 * n2, offset=pos).reshape(n2, n1)
    return header, data.astype(dtype[1:])
