#!/usr/bin/env python3
"""Crops NRRD volumes (attached data, raw or gzip; 3-D or 4-D with a leading per-voxel axis) to a
voxel box, keeping their geometry: the space origin moves to the box's first voxel, so every
position in patient coordinates (LPS, mm) stays where it was. Standard library only.

    crop-nrrd.py I0:I1 J0:J1 K0:K1 IN.nrrd OUT.nrrd [IN.nrrd OUT.nrrd ...]

The box is half-open voxel index ranges along the volume's i, j, k axes (clamped to the volume).
Used by scripts/segmented-sample.sh to make the committed segmented sample.
"""
import gzip
import re
import sys


def crop(box, src, dst):
    data = open(src, "rb").read()
    end = data.index(b"\n\n")
    header = data[:end].decode("latin-1").split("\n")
    body = data[end + 2:]
    fields = {}
    for line in header[1:]:
        if line.startswith("#") or ": " not in line:
            continue
        key, value = line.split(": ", 1)
        fields[key.strip().lower()] = value.strip()
    sizes = [int(s) for s in fields["sizes"].split()]
    lead = 1 if len(sizes) == 4 else 0
    bytes_per = {"float": 4, "double": 8, "unsigned char": 1, "uchar": 1, "uint8": 1,
                 "short": 2, "int16": 2, "unsigned short": 2, "uint16": 2}[fields["type"]]
    voxel = bytes_per * (sizes[0] if lead else 1)
    nx, ny, nz = sizes[lead:lead + 3]
    lo = [max(0, b[0]) for b in box]
    hi = [min(n, b[1]) for b, n in zip(box, (nx, ny, nz))]
    if any(h <= l for l, h in zip(lo, hi)):
        sys.exit(f"{src}: the box {box} holds no voxel of the {nx}x{ny}x{nz} volume")
    raw = gzip.decompress(body) if fields.get("encoding") in ("gzip", "gz") else body
    if len(raw) < nx * ny * nz * voxel:
        sys.exit(f"{src}: the data is shorter than its sizes say")
    out = bytearray()
    row = (hi[0] - lo[0]) * voxel
    for k in range(lo[2], hi[2]):
        for j in range(lo[1], hi[1]):
            start = ((k * ny + j) * nx + lo[0]) * voxel
            out += raw[start:start + row]
    # The space origin moves by lo along the space directions.
    directions = re.findall(r"\(([^)]*)\)", fields["space directions"])
    origin = [float(x) for x in re.findall(r"\(([^)]*)\)", fields["space origin"])[0].split(",")]
    for a, d in enumerate(directions):
        v = [float(x) for x in d.split(",")]
        origin = [o + lo[a] * c for o, c in zip(origin, v)]
    new_sizes = sizes[:lead] + [h - l for l, h in zip(lo, hi)]
    lines = []
    for line in header:
        key = line.split(": ", 1)[0].strip().lower() if ": " in line else ""
        if key == "sizes":
            line = "sizes: " + " ".join(str(s) for s in new_sizes)
        elif key == "space origin":
            line = "space origin: (" + ",".join(repr(o) for o in origin) + ")"
        elif key == "encoding":
            line = "encoding: gzip"
        lines.append(line)
    lines.insert(1, f"# cropped to voxels [{lo[0]},{hi[0]}) x [{lo[1]},{hi[1]}) x "
                    f"[{lo[2]},{hi[2]}) by scripts/crop-nrrd.py")
    with open(dst, "wb") as f:
        f.write(("\n".join(lines) + "\n\n").encode("latin-1"))
        f.write(gzip.compress(bytes(out), 9, mtime=0))


def main(argv):
    if len(argv) < 6 or (len(argv) - 4) % 2:
        sys.exit(__doc__)
    box = [tuple(int(x) for x in a.split(":")) for a in argv[1:4]]
    for src, dst in zip(argv[4::2], argv[5::2]):
        crop(box, src, dst)


if __name__ == "__main__":
    main(sys.argv)
