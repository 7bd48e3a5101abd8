// Loads one glTF/GLB with three.js's GLTFLoader, renders it at the requested animation times and
// reports what the pixels show (render-gltf.js serves this page and collects the report).
//
// Query: ?model=URL&w=800&h=600&yaw=0&pitch=0&times=first,last&section=0
//   The camera orbits the model's bounding box centre: yaw 0 looks from +Z (the glTF front; in
//   tsf's y-up axes the patient's anterior) toward −Z with +Y (superior) up; yaw 90 looks from +X.
//   times: seconds or "first" / "last" (the first and last keyframe of the longest clip).
//   section=1: cut away the +X half (in tsf's y-up axes the patient's left) through the model's
//   centre, drawing both sides of every surface, to show what lies inside.
// The report is POSTed to /result as JSON: the scene (nodes, materials, animations, bounds) and,
// per time, the PNG (data URL) and pixel statistics (see stats()).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

const BACKGROUND = [24, 26, 32];  // sRGB bytes; anything else is the model
const INTERPOLATION = { [THREE.InterpolateDiscrete]: 'STEP', [THREE.InterpolateLinear]: 'LINEAR',
                        [THREE.InterpolateSmooth]: 'CUBICSPLINE' };

function post(report) {
  return fetch('/result', { method: 'POST', body: JSON.stringify(report) });
}

// Pixel statistics of one RGBA image (rows top to bottom).
function stats(pixels, w, h) {
  let covered = 0, chromatic = 0;
  const sum = [0, 0, 0];
  const rowCount = new Array(h).fill(0);
  let top = h, bottom = -1, left = w, right = -1;
  for (let y = 0; y < h; ++y) {
    for (let x = 0; x < w; ++x) {
      const i = 4 * (y * w + x);
      const r = pixels[i], g = pixels[i + 1], b = pixels[i + 2];
      const d = Math.abs(r - BACKGROUND[0]) + Math.abs(g - BACKGROUND[1]) + Math.abs(b - BACKGROUND[2]);
      if (d <= 6) continue;
      ++covered;
      ++rowCount[y];
      sum[0] += r; sum[1] += g; sum[2] += b;
      if (Math.max(r, g, b) - Math.min(r, g, b) >= 24) ++chromatic;
      top = Math.min(top, y); bottom = Math.max(bottom, y);
      left = Math.min(left, x); right = Math.max(right, x);
    }
  }
  const s = {
    width: w, height: h, covered_pixels: covered, covered_fraction: covered / (w * h),
    chromatic_fraction: covered ? chromatic / covered : 0,
    mean_rgb: covered ? sum.map((v) => v / covered) : [0, 0, 0],
  };
  if (covered) {
    // Mean silhouette width over the top and bottom 15 % of the model's rows.
    const rows = bottom - top + 1, band = Math.max(1, Math.round(0.15 * rows));
    let tw = 0, bw = 0;
    for (let y = top; y < top + band; ++y) tw += rowCount[y];
    for (let y = bottom - band + 1; y <= bottom; ++y) bw += rowCount[y];
    Object.assign(s, { bbox: { top, bottom, left, right }, top_band_width: tw / band,
                       bottom_band_width: bw / band });
  }
  return s;
}

function changedFraction(a, b) {
  let changed = 0;
  for (let i = 0; i < a.length; i += 4)
    if (Math.abs(a[i] - b[i]) + Math.abs(a[i + 1] - b[i + 1]) + Math.abs(a[i + 2] - b[i + 2]) > 24)
      ++changed;
  return changed / (a.length / 4);
}

async function main() {
  const q = new URLSearchParams(location.search);
  const w = Number(q.get('w') || 800), h = Number(q.get('h') || 600);
  const yaw = THREE.MathUtils.degToRad(Number(q.get('yaw') || 0));
  const pitch = THREE.MathUtils.degToRad(Number(q.get('pitch') || 0));
  const canvas = document.createElement('canvas');
  canvas.width = w; canvas.height = h;
  document.body.appendChild(canvas);
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setSize(w, h, false);
  renderer.setClearColor(new THREE.Color().setRGB(...BACKGROUND.map((c) => c / 255), THREE.SRGBColorSpace));

  const gltf = await new GLTFLoader().loadAsync(q.get('model'));
  const scene = new THREE.Scene();
  scene.add(gltf.scene);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x404050, 1.2));

  const report = { three: THREE.REVISION, nodes: [], materials: [], animations: [], frames: [] };
  const materials = new Map();
  gltf.scene.traverse((o) => {
    report.nodes.push({ name: o.name, type: o.type, visible: o.visible });
    if (o.isMesh)
      for (const m of Array.isArray(o.material) ? o.material : [o.material])
        materials.set(m.uuid, m);
  });
  for (const m of materials.values())
    report.materials.push({ name: m.name, color: m.color.getHexString(), roughness: m.roughness,
                            metalness: m.metalness, vertexColors: m.vertexColors });
  let clip = null;
  for (const a of gltf.animations) {
    const times = a.tracks.length ? a.tracks[0].times : [];
    report.animations.push({ name: a.name, duration: a.duration, tracks: a.tracks.length,
                             keyframes: times.length,
                             interpolations: [...new Set(a.tracks.map((t) => INTERPOLATION[t.getInterpolation()] ||
                                                                           String(t.getInterpolation())))] });
    if (!clip || a.duration > clip.duration) clip = a;
  }
  const mixer = clip ? new THREE.AnimationMixer(gltf.scene) : null;
  const action = mixer ? mixer.clipAction(clip) : null;
  if (action) {
    // Once, held at the end: a looping clip would wrap its last keyframe time round to 0.
    action.setLoop(THREE.LoopOnce, 1);
    action.clampWhenFinished = true;
  }
  // The pose at time t (a finished LoopOnce action stays paused: start it afresh each time).
  const poseAt = (t) => {
    if (!action) return;
    action.reset();
    action.play();
    mixer.setTime(t);
  };

  const timeOf = (t) => {
    if (t === 'first') return 0;
    if (t === 'last') return clip ? clip.duration : 0;
    return Number(t);
  };
  const times = (q.get('times') || 'first').split(',').map(timeOf);

  // Camera and light from the bounding box of the poses at every requested time. Meshes hidden
  // by a zero scale (the states of a cut animation not showing) do not count.
  const box = new THREE.Box3();
  for (const t of times) {
    poseAt(t);
    gltf.scene.updateMatrixWorld(true);
    gltf.scene.traverse((o) => {
      if (o.isMesh && Math.abs(o.matrixWorld.determinant()) > 0) box.expandByObject(o);
    });
  }
  const centre = box.getCenter(new THREE.Vector3()), size = box.getSize(new THREE.Vector3());
  report.bounds = { min: box.min.toArray(), max: box.max.toArray() };
  const radius = 0.5 * size.length();
  const camera = new THREE.PerspectiveCamera(30, w / h, radius / 100, radius * 100);
  const dir = new THREE.Vector3(Math.sin(yaw) * Math.cos(pitch), Math.sin(pitch),
                                Math.cos(yaw) * Math.cos(pitch));
  const distance = radius / Math.sin(THREE.MathUtils.degToRad(15)) * 1.05;
  camera.position.copy(centre).addScaledVector(dir, distance);
  camera.up.set(0, 1, 0);
  camera.lookAt(centre);
  if (q.get('section') === '1') {
    renderer.clippingPlanes = [new THREE.Plane(new THREE.Vector3(-1, 0, 0), centre.x)];
    for (const m of materials.values()) m.side = THREE.DoubleSide;
  }
  const light = new THREE.DirectionalLight(0xffffff, 1.8);
  light.position.copy(camera.position).add(new THREE.Vector3(0, radius, 0));
  light.target.position.copy(centre);
  scene.add(light, light.target);

  const gl = renderer.getContext();
  let first = null;
  for (const t of times) {
    poseAt(t);
    renderer.render(scene, camera);
    const pixels = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
    // readPixels rows run bottom to top: flip so row 0 is the top of the picture.
    const flipped = new Uint8Array(pixels.length);
    for (let y = 0; y < h; ++y)
      flipped.set(pixels.subarray((h - 1 - y) * w * 4, (h - y) * w * 4), y * w * 4);
    const frame = { time: t, stats: stats(flipped, w, h), png: canvas.toDataURL('image/png') };
    if (first) frame.changed_fraction_from_first = changedFraction(first, flipped);
    else first = flipped;
    report.frames.push(frame);
  }
  await post(report);
}

main().catch((e) => post({ error: String(e && e.stack ? e.stack : e) }));
