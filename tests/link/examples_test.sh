#!/bin/sh
# OpenIGTLink's own example programs (Debian openigtlink-examples, built here from their sources)
# against a live `tsf link` on localhost (docs/live.md, "Checked against OpenIGTLink's examples"):
#   1. TrackerClient streams TRANSFORM 'Tracker' (a circle of 50 mm, printed as it sends): the
#      scene's stylus follows it: every pose tsf applied is a matrix the tracker sent, in patient
#      LPS (RAS on the wire: x and y negated).
#   2. PolyDataClient asks for POLYDATA (GET_POLYDATA, ten times, 0.5 s apart) before the
#      scene's scripted cut, and again after it: the surface it received changed (more
#      triangles), and the last one it received is the mesh tsf exports at the end (final.ply,
#      patient LPS), point for point.
#   3. `tsf view --offscreen --igtl-port` serves the same scene's surface to PolyDataClient.
# Usage: examples_test.sh SOURCE_DIR TSF CMAKE WORK_DIR
set -eu
SRC=$1
TSF=$2
CMAKE=$3
WORK=$4
EXAMPLES=/usr/share/doc/openigtlink-examples/examples
if [ ! -f "$EXAMPLES/Tracker/TrackerClient.cxx" ] || [ ! -f "$EXAMPLES/PolyData/PolyDataClient.cxx" ]; then
  echo "FAIL: OpenIGTLink's examples are not installed (Debian: openigtlink-examples)" >&2
  exit 1
fi
rm -rf "$WORK"
mkdir -p "$WORK"
cd "$WORK"

# Build the two example clients from their own CMake projects (as their README says).
for d in Tracker PolyData; do
  "$CMAKE" -S "$EXAMPLES/$d" -B "build-$d" -DCMAKE_BUILD_TYPE=Release >"build-$d.log" 2>&1 ||
    { cat "build-$d.log" >&2; exit 1; }
done
"$CMAKE" --build build-Tracker --target TrackerClient >>build-Tracker.log 2>&1 ||
  { cat build-Tracker.log >&2; exit 1; }
"$CMAKE" --build build-PolyData --target PolyDataClient >>build-PolyData.log 2>&1 ||
  { cat build-PolyData.log >&2; exit 1; }

TSF_PID=""
TRACKER_PID=""
cleanup() {
  [ -n "$TRACKER_PID" ] && kill "$TRACKER_PID" 2>/dev/null || true
  [ -n "$TSF_PID" ] && kill "$TSF_PID" 2>/dev/null || true
}
trap cleanup EXIT

# wait_for FILE PATTERN SECONDS: until a line of FILE matches PATTERN (or tsf ended: fail).
wait_for() {
  i=0
  while ! grep -q "$2" "$1" 2>/dev/null; do
    i=$((i + 1))
    if [ "$i" -gt $(($3 * 10)) ] || ! kill -0 "$TSF_PID" 2>/dev/null; then
      echo "FAIL: waited for '$2' in $1" >&2
      cat "$1" >&2
      exit 1
    fi
    sleep 0.1
  done
}

# wait_ok LOG WHAT: tsf (TSF_PID) ends with status 0, else fail showing LOG.
wait_ok() {
  status=0
  wait "$TSF_PID" || status=$?
  TSF_PID=""
  if [ "$status" -ne 0 ]; then
    echo "FAIL: $2 exited with $status" >&2
    cat "$1" >&2
    exit 1
  fi
}

# A live session on a free port; the stylus follows 'Tracker'. It runs until stopped (Ctrl-C).
"$TSF" link "$SRC/scenes/link-block.yaml" --igtl-port 0 --igtl-tool stylus=Tracker:press \
  --seconds 600 --out session >tsf.log 2>&1 &
TSF_PID=$!
wait_for tsf.log "listening on 127.0.0.1:" 60
PORT=$(sed -n 's/.*listening on 127\.0\.0\.1:\([0-9]*\).*/\1/p' tsf.log | head -n 1)
wait_for tsf.log "running (session time 0" 120
echo "tsf link serves port $PORT"

stdbuf -oL build-Tracker/TrackerClient 127.0.0.1 "$PORT" 20 >tracker.txt 2>&1 &
TRACKER_PID=$!
# Before the cut (the scene cuts one second of session time in; the first request is answered
# at once with the newest surface).
build-PolyData/PolyDataClient 127.0.0.1 "$PORT" >polydata-before.txt 2>&1
kill "$TRACKER_PID"
wait "$TRACKER_PID" 2>/dev/null || true
TRACKER_PID=""
# The cut reaches the served surface; give the slab a few seconds to come to rest, then ask again.
wait_for tsf.log "served surface .* triangles" 120
sleep 4
build-PolyData/PolyDataClient 127.0.0.1 "$PORT" >polydata-after.txt 2>&1
kill -TERM "$TSF_PID"
wait_ok tsf.log "tsf link"
cat tsf.log

# 3. tsf view serves the same surface (--igtl-port): offscreen frames of the same scene, asked
#    by PolyDataClient while they render. Needs X (scripts/test.sh gives ctest a virtual display).
XRUN=""
[ -z "${DISPLAY:-}" ] && XRUN="xvfb-run -a"
$XRUN "$TSF" view "$SRC/scenes/link-block.yaml" --offscreen --frames 40 --width 320 --height 240 \
  --igtl-port 0 --out view --force >view.log 2>&1 &
TSF_PID=$!
wait_for view.log "listening on 127.0.0.1:" 120
PORT=$(sed -n 's/.*listening on 127\.0\.0\.1:\([0-9]*\).*/\1/p' view.log | head -n 1)
build-PolyData/PolyDataClient 127.0.0.1 "$PORT" >polydata-view.txt 2>&1 || true
wait_ok view.log "tsf view --igtl-port"

python3 - <<'EOF'
import json, struct, sys

def fail(msg):
    print("FAIL: " + msg, file=sys.stderr)
    sys.exit(1)

# 1. The tool follows the transforms.
sent = []
rows = []
for line in open("tracker.txt"):
    line = line.strip()
    if line.startswith("====="):
        if len(rows) == 4:
            sent.append([float(rows[r][3]) for r in range(3)])
        rows = []
    elif line.count(",") == 3:
        rows.append(line.split(","))
report = json.load(open("session/link-report.json"))
link = report["link"]
tool = [t for t in link["tools"] if t["tool"] == "stylus"][0]
trace = tool["trace"]
if len(sent) < 5 or len(trace) < 5:
    fail("the tracker sent %d poses, tsf applied %d (expected several)" % (len(sent), len(trace)))
for t, x, y, z, n in trace:
    n = int(n)
    if n > len(sent):
        fail("tsf applied TRANSFORM #%d, the tracker printed %d" % (n, len(sent)))
    r, a, s = sent[n - 1]
    if max(abs(x + r), abs(y + a), abs(z - s)) > 1e-3 * max(1.0, abs(r), abs(a), abs(s)):
        fail("pose #%d: tsf applied LPS (%g, %g, %g), the tracker sent RAS (%g, %g, %g)" % (n, x, y, z, r, a, s))
distinct = {tuple(round(v, 3) for v in row[1:4]) for row in trace}
print("tool: %d TRANSFORMs sent, %d applied (%d distinct positions), every one the tracker's (RAS -> LPS)"
      % (len(sent), len(trace), len(distinct)))
if len(distinct) < 5:
    fail("the stylus did not move with the tracker")

# 2. The received POLYDATA.
def replies(path):
    out = []
    cur = None
    for line in open(path):
        line = line.strip()
        if line.startswith("========== PolyData Contents"):
            cur = {"points": [], "cells": 0, "triangles": [], "normals": []}
            attribute = ""
            out.append(cur)
        elif cur is not None and line.startswith("Name = "):
            attribute = line[len("Name = "):]
        elif cur is not None and line.startswith("data[") and attribute == "Normals":
            v = line.split("=", 1)[1].strip().strip("()").split(",")
            cur["normals"].append(tuple(float(c) for c in v))
        elif cur is not None and line.startswith("point["):
            v = line.split("=", 1)[1].strip().strip("()").split(",")
            cur["points"].append(tuple(float(c) for c in v))
        elif cur is not None and line.startswith("cell["):
            # The example prints a cell's first index twice: "(a, a, b, c)".
            v = [int(c) for c in line.split("=", 1)[1].strip().strip("()").split(",")]
            cur["triangles"].append(tuple(v[-3:]))
            cur["cells"] += 1
    return out

before = replies("polydata-before.txt")
after = replies("polydata-after.txt")
if len(before) != 10 or len(after) != 10:
    fail("PolyDataClient received %d and %d POLYDATA (10 each expected)" % (len(before), len(after)))
first, last = before[0], after[-1]
print("POLYDATA: first %d points %d triangles; after the cut %d points %d triangles"
      % (len(first["points"]), first["cells"], len(last["points"]), last["cells"]))
if last["cells"] <= first["cells"]:
    fail("the served surface did not change after the cut")

def read_ply(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    if "format binary_little_endian 1.0" not in header:
        fail(path + ": not a binary little-endian PLY")
    sizes = {"float": "f", "float32": "f", "double": "d", "uchar": "B", "uint8": "B",
             "int": "i", "int32": "i", "uint": "I", "uint32": "I", "short": "h", "ushort": "H"}
    elements = []
    for h in header:
        w = h.split()
        if w[0] == "element":
            elements.append([w[1], int(w[2]), []])
        elif w[0] == "property":
            elements[-1][2].append(w[1:])
    at = end
    verts, faces = [], []
    for name, count, props in elements:
        if name == "vertex":
            fmt = "<" + "".join(sizes[p[0]] for p in props)
            names = [p[-1] for p in props]
            size = struct.calcsize(fmt)
            ix, iy, iz = names.index("x"), names.index("y"), names.index("z")
            for i in range(count):
                v = struct.unpack_from(fmt, data, at)
                verts.append((v[ix], v[iy], v[iz]))
                at += size
        elif name == "face":
            p = props[0]
            cnt, idx = sizes[p[1]], sizes[p[2]]
            for i in range(count):
                n = struct.unpack_from("<" + cnt, data, at)[0]
                at += struct.calcsize(cnt)
                faces.append(struct.unpack_from("<" + idx * n, data, at))
                at += n * struct.calcsize(idx)
    return verts, faces

verts, faces = read_ply("session/final.ply")
if len(faces) != last["cells"] or len(verts) != len(last["points"]):
    fail("the last POLYDATA (%d points, %d triangles) is not the exported mesh (%d, %d)"
         % (len(last["points"]), last["cells"], len(verts), len(faces)))
if [tuple(f) for f in faces] != last["triangles"]:
    fail("the last POLYDATA's triangles are not the exported mesh's")
worst = 0.0
for (x, y, z), (r, a, s) in zip(verts, last["points"]):
    worst = max(worst, abs(x + r), abs(y + a), abs(z - s))
print("last POLYDATA vs exported final.ply: %d points, largest difference %.4f mm (RAS -> LPS)"
      % (len(verts), worst))
if worst > 0.05:
    fail("the last POLYDATA differs from the exported mesh by %.4f mm" % worst)
# 3. tsf view served its surface: its first is the rest surface tsf link served first.
view = replies("polydata-view.txt")
if not view:
    fail("PolyDataClient received no POLYDATA from tsf view --igtl-port")
v0 = view[0]
if v0["triangles"] != first["triangles"] or len(v0["points"]) != len(first["points"]):
    fail("tsf view's first surface (%d points) is not tsf link's (%d)" % (len(v0["points"]), len(first["points"])))
worst_view = max(max(abs(a - b) for a, b in zip(p, q)) for p, q in zip(v0["points"], first["points"]))
print("tsf view --igtl-port: %d POLYDATA received; the first is tsf link's first (largest difference %.4f mm)"
      % (len(view), worst_view))
if worst_view > 0.05:
    fail("tsf view's first surface differs from tsf link's by %.4f mm" % worst_view)

# The surfaces as received (RAS, mm), for a picture (docs/live.md).
for name, reply in (("received-before.ply", first), ("received-after.ply", last)):
    with open(name, "w") as out:
        out.write("ply\nformat ascii 1.0\ncomment OpenIGTLink POLYDATA as received, RAS mm\n")
        out.write("element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(reply["points"]))
        out.write("property float nx\nproperty float ny\nproperty float nz\n")
        out.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(reply["triangles"]))
        if len(reply["normals"]) != len(reply["points"]):
            fail("a POLYDATA without its 'Normals' point attribute")
        for p, n in zip(reply["points"], reply["normals"]):
            out.write("%g %g %g %g %g %g\n" % (p + n))
        for t in reply["triangles"]:
            out.write("3 %d %d %d\n" % t)
print("surface: rate %.1f/s, %d bytes per POLYDATA" % (link["surface"]["rate_hz"], link["surface"]["message_bytes"]))
EOF
echo "PASS"
