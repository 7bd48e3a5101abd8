#!/usr/bin/env bash
# docs/images/rest-on-bone.png: scenes/rest-on-bone.yaml run with its instance contact and without
# it (the `contact:` line removed), each drawn as a side view (x, z) of the final surfaces' vertices
# within 0.6 mm of the mid-plane y = 6 (tissue space = patient LPS here, mm).
#
#   scripts/rest-on-bone-picture.sh [OUT.png]      (default docs/images/rest-on-bone.png)
# Needs build/bin/tsf, python3 and gnuplot.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tsf="${TSF:-$root/build/bin/tsf}"
out="${1:-$root/docs/images/rest-on-bone.png}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
sed '/contact: {pushed_by: \[bone\]}/d' "$root/scenes/rest-on-bone.yaml" > "$tmp/no-contact.yaml"
"$tsf" simulate -q --backend cpu "$root/scenes/rest-on-bone.yaml" --out "$tmp/on"
"$tsf" simulate -q --backend cpu "$tmp/no-contact.yaml" --out "$tmp/off"
python3 - "$tmp" <<'PY'
import struct, sys
tmp = sys.argv[1]
def vertices(path):
    data = open(path, 'rb').read()
    end = data.index(b'end_header\n') + len(b'end_header\n')
    header = data[:end].decode().splitlines()
    count = next(int(l.split()[2]) for l in header if l.startswith('element vertex'))
    props = []
    reading = False
    for l in header:
        if l.startswith('element'): reading = l.startswith('element vertex')
        elif l.startswith('property') and reading: props.append(l.split()[1])
    size = {'float': 4, 'uchar': 1, 'int': 4}
    fmt = '<' + ''.join({'float': 'f', 'uchar': 'B', 'int': 'i'}[p] for p in props)
    stride = sum(size[p] for p in props)
    return [struct.unpack_from(fmt, data, end + i * stride)[:3] for i in range(count)]
for run in ('on', 'off'):
    for inst in ('soft', 'bone'):
        with open(f'{tmp}/{run}-{inst}.dat', 'w') as f:
            for x, y, z in vertices(f'{tmp}/{run}/final-{inst}.ply'):
                if abs(y - 6.0) < 0.6: f.write(f'{x} {z}\n')
PY
gnuplot <<GP
set terminal pngcairo size 1200,520 font 'Sans,11'
set output '$out'
set multiplot layout 1,2 title 'scenes/rest-on-bone.yaml after 0.25 s: side view of the mid-plane (y = 6 mm), tissue space mm'
set size ratio -1
set xrange [-2:42]; set yrange [-14:18]
set xlabel 'x (mm)'; set ylabel 'z (mm)'
set key top left
set title 'contact: {pushed\_by: [bone]} — the block rests on the bone'
plot '$tmp/on-bone.dat' with points pt 7 ps 0.25 lc rgb '#8c8c8c' title 'bone (held along its underside)', \
     '$tmp/on-soft.dat' with points pt 7 ps 0.25 lc rgb '#d9534f' title 'soft block (held by nothing)'
set title 'no contact — the block falls through the bone'
plot '$tmp/off-bone.dat' with points pt 7 ps 0.25 lc rgb '#8c8c8c' title 'bone', \
     '$tmp/off-soft.dat' with points pt 7 ps 0.25 lc rgb '#d9534f' title 'soft block'
unset multiplot
GP
echo "wrote $out"
