// pano4d's 4D viewer (index.html): the compact 4D scene (scene4d.json and
// scene4d.bin, src/gs/scene4d.h) drawn by Spark (@sparkjsdev/spark, a
// three.js Gaussian splat renderer), with a time slider, orbit and fly
// controls, the training and expanded cameras as frusta and the panorama
// centre.
//
// The dynamic Gaussians are posed on the CPU whenever the time changes,
// with the formula of src/gs/motion.h: with w = softmax(logits),
//   q_b = sum_k w_k q_k(t), t_b = sum_k w_k tau_k(t),
//   mu(t) = R(q_b / |q_b|) mu_c + t_b,   q(t) = q_b (x) q_c.
//
// ?capture=FILE (for tests): renders each {"name", "camera", "t"} of FILE
// at the camera's size, POSTs the PNG to /capture/NAME.png, then the frame
// rate to /capture/done.json, and an error to /capture/error.json.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { PackedSplats, SparkRenderer, SplatMesh } from "@sparkjsdev/spark";

// As the CPU rasterizer (src/render/rasterizer.h): the 0.3 pixel low-pass
// (kLowPass), fragments below 1/255 skipped (kMinAlpha), 3 sigma, depth
// order, the near plane.
const kLowPass = 0.3;
const kMinAlpha = 1 / 255;
const kMaxStdDev = 3;
const kNearPlane = 0.01;
const kSh0 = 0.28209479177387814;
// A blended basis rotation shorter than this is the identity
// (kMinBlendedQuaternionNorm in src/gs/motion.h).
const kMinBlendedQuaternionNorm = 1e-6;
const kPlayFps = 10;

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);

// float16 bits -> float, by table.
const kHalf = (() => {
  const table = new Float32Array(65536);
  for (let h = 0; h < 65536; ++h) {
    const s = h & 0x8000 ? -1 : 1, e = (h >> 10) & 0x1f, m = h & 0x3ff;
    table[h] = e === 0 ? s * m * 2 ** -24
             : e === 31 ? (m ? NaN : s * Infinity)
             : s * (1 + m / 1024) * 2 ** (e - 15);
  }
  return table;
})();

function arrayOf(buffer, a, name) {
  const n = a.shape.reduce((x, y) => x * y, 1);
  const bytes = a.dtype === "float32" ? 4 : 2;
  if (a.offset + n * bytes > buffer.byteLength)
    throw new Error(`scene4d.json: ${name} lies outside scene4d.bin`);
  let out;
  if (a.dtype === "float32") {
    out = new Float32Array(buffer, a.offset, n);
  } else {
    const bits = new Uint16Array(buffer, a.offset, n);
    out = new Float32Array(n);
    for (let i = 0; i < n; ++i) out[i] = kHalf[bits[i]];
  }
  // A NaN would be drawn as a splat at no place: refuse the file instead.
  for (let i = 0; i < n; ++i)
    if (!Number.isFinite(out[i]))
      throw new Error(`scene4d.bin: ${name}[${i}] is not finite`);
  return out;
}

function gaussianSet(buffer, header, set) {
  const s = header[set], arrays = {};
  if (!Number.isInteger(s.count) || s.count < 0)
    throw new Error(`scene4d.json: ${set}.count ${s.count} is not a count`);
  for (const [name, a] of Object.entries(s.arrays)) {
    arrays[name] = arrayOf(buffer, a, `${set}.${name}`);
    // Every array holds one row per Gaussian: a larger count would read
    // past its end.
    if (a.shape[0] !== s.count)
      throw new Error(`scene4d.json: ${set}.${name} has ${a.shape[0]} rows, ${set}.count says ${s.count}`);
  }
  return { count: s.count, coefficients: (header.sh_degree + 1) ** 2, ...arrays };
}

async function loadScene() {
  const response = await fetch("scene4d.json");
  if (!response.ok) throw new Error(`scene4d.json: HTTP ${response.status}`);
  const header = await response.json();
  if (header.format !== "pano4d-scene4d" || header.version !== 1)
    throw new Error(`scene4d.json: format ${header.format} version ${header.version}, expected pano4d-scene4d 1`);
  const binary = await fetch(header.binary);
  const buffer = await binary.arrayBuffer();
  if (buffer.byteLength !== header.binary_bytes)
    throw new Error(`${header.binary}: ${buffer.byteLength} bytes, scene4d.json says ${header.binary_bytes}`);
  const scene = {
    header,
    statics: gaussianSet(buffer, header, "statics"),
    dynamics: gaussianSet(buffer, header, "dynamics"),
    bases: { count: header.bases.count },
    extras: header.extras || {},
  };
  if (scene.bases.count > 0) {
    scene.bases.rotations = arrayOf(buffer, header.bases.arrays.rotations, "bases.rotations");
    scene.bases.translations = arrayOf(buffer, header.bases.arrays.translations, "bases.translations");
  }
  // Softmax of the logits, once.
  const m = scene.dynamics.count, k = scene.bases.count;
  const w = new Float32Array(m * k);
  for (let i = 0; i < m; ++i) {
    let max = -Infinity, sum = 0;
    for (let j = 0; j < k; ++j) max = Math.max(max, scene.dynamics.logits[i * k + j]);
    for (let j = 0; j < k; ++j) sum += (w[i * k + j] = Math.exp(scene.dynamics.logits[i * k + j] - max));
    for (let j = 0; j < k; ++j) w[i * k + j] /= sum;
  }
  scene.dynamics.weights = w;
  return scene;
}

const sigmoid = (x) => 1 / (1 + Math.exp(-x));
const clamp01 = (x) => Math.min(1, Math.max(0, x));

// One splat's appearance (scales, opacity, colour from the SH DC term:
// Spark draws degree 0 here, see docs/ARCHITECTURE.md).
function appearance(g, i, scales, color) {
  scales.set(Math.exp(g.log_scales[i * 3]), Math.exp(g.log_scales[i * 3 + 1]),
             Math.exp(g.log_scales[i * 3 + 2]));
  const sh = i * g.coefficients * 3;
  color.setRGB(clamp01(0.5 + kSh0 * g.sh[sh]), clamp01(0.5 + kSh0 * g.sh[sh + 1]),
               clamp01(0.5 + kSh0 * g.sh[sh + 2]));
  return sigmoid(g.opacities[i]);
}

function staticSplats(g) {
  const packed = new PackedSplats({ maxSplats: Math.max(1, g.count) });
  const c = new THREE.Vector3(), s = new THREE.Vector3(), q = new THREE.Quaternion(), col = new THREE.Color();
  for (let i = 0; i < g.count; ++i) {
    const o = appearance(g, i, s, col);
    c.set(g.means[i * 3], g.means[i * 3 + 1], g.means[i * 3 + 2]);
    q.set(g.quats[i * 4 + 1], g.quats[i * 4 + 2], g.quats[i * 4 + 3], g.quats[i * 4]);
    packed.pushSplat(c, s, q, o, col);
  }
  return packed;
}

// The dynamic Gaussians, posed at a time on demand.
class DynamicSplats {
  constructor(scene) {
    this.g = scene.dynamics;
    this.bases = scene.bases;
    this.times = scene.header.num_times;
    this.packed = new PackedSplats({ maxSplats: Math.max(1, this.g.count) });
    const c = new THREE.Vector3(), s = new THREE.Vector3(), q = new THREE.Quaternion(), col = new THREE.Color();
    this.scales = [], this.opacity = [], this.colors = [];
    for (let i = 0; i < this.g.count; ++i) {
      this.opacity.push(appearance(this.g, i, s, col));
      this.scales.push(s.clone());
      this.colors.push(col.clone());
      this.packed.pushSplat(c, s, q, this.opacity[i], col);
    }
    this.time = -1;
  }

  pose(t, mesh) {
    if (t === this.time || this.g.count === 0) return;
    this.time = t;
    const g = this.g, k = this.bases.count, T = this.times;
    const R = this.bases.rotations, Tr = this.bases.translations;
    const c = new THREE.Vector3(), q = new THREE.Quaternion();
    for (let i = 0; i < g.count; ++i) {
      let qw = 0, qx = 0, qy = 0, qz = 0, tx = 0, ty = 0, tz = 0;
      for (let j = 0; j < k; ++j) {
        const w = g.weights[i * k + j], r = (j * T + t) * 4, tr = (j * T + t) * 3;
        qw += w * R[r]; qx += w * R[r + 1]; qy += w * R[r + 2]; qz += w * R[r + 3];
        tx += w * Tr[tr]; ty += w * Tr[tr + 1]; tz += w * Tr[tr + 2];
      }
      let n2 = qw * qw + qx * qx + qy * qy + qz * qz;
      if (!(n2 >= kMinBlendedQuaternionNorm ** 2)) { qw = 1; qx = qy = qz = 0; n2 = 1; }
      const mx = g.means[i * 3], my = g.means[i * 3 + 1], mz = g.means[i * 3 + 2];
      // M(q) mu / |q|^2, as RotateUnnormalised in src/gs/motion.cc.
      c.set(((qw * qw + qx * qx - qy * qy - qz * qz) * mx + 2 * (qx * qy - qw * qz) * my + 2 * (qx * qz + qw * qy) * mz) / n2 + tx,
            (2 * (qx * qy + qw * qz) * mx + (qw * qw - qx * qx + qy * qy - qz * qz) * my + 2 * (qy * qz - qw * qx) * mz) / n2 + ty,
            (2 * (qx * qz - qw * qy) * mx + 2 * (qy * qz + qw * qx) * my + (qw * qw - qx * qx - qy * qy + qz * qz) * mz) / n2 + tz);
      const cw = g.quats[i * 4], cx = g.quats[i * 4 + 1], cy = g.quats[i * 4 + 2], cz = g.quats[i * 4 + 3];
      q.set(qw * cx + qx * cw + qy * cz - qz * cy,
            qw * cy - qx * cz + qy * cw + qz * cx,
            qw * cz + qx * cy - qy * cx + qz * cw,
            qw * cw - qx * cx - qy * cy - qz * cz).normalize();
      this.packed.setSplat(i, c, this.scales[i], q, this.opacity[i], this.colors[i]);
    }
    this.packed.needsUpdate = true;
    mesh.needsUpdate = true;
  }
}

// A camera of the JSON layout (src/pano/trajectory.h CameraToJson:
// cam_from_world qvec (w x y z), tvec; pinhole fx fy cx cy) as a three.js
// pose (camera looks down -z, y up) and projection.
function cameraPose(j) {
  const [w, x, y, z] = j.qvec;
  const R = new THREE.Matrix3().set(
    1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
    2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
    2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y));
  const Rt = R.clone().transpose();
  const t = new THREE.Vector3(...j.tvec);
  const centre = t.clone().applyMatrix3(Rt).negate();
  const e = Rt.elements;  // column-major: columns are the camera axes
  const right = new THREE.Vector3(e[0], e[1], e[2]);
  const down = new THREE.Vector3(e[3], e[4], e[5]);
  const forward = new THREE.Vector3(e[6], e[7], e[8]);
  const m = new THREE.Matrix4().makeBasis(right, down.clone().negate(), forward.clone().negate());
  return { centre, quaternion: new THREE.Quaternion().setFromRotationMatrix(m), right, down, forward };
}

// OpenGL projection of a pinhole camera, principal point included.
function projection(j, near, far) {
  const { width: W, height: H, fx, fy, cx, cy } = j;
  return new THREE.Matrix4().set(
    2 * fx / W, 0, 1 - 2 * cx / W, 0,
    0, 2 * fy / H, 2 * cy / H - 1, 0,
    0, 0, -(far + near) / (far - near), -2 * far * near / (far - near),
    0, 0, -1, 0);
}

function frustum(j, depth) {
  const p = cameraPose(j);
  const corner = (u, v) => p.centre.clone()
    .addScaledVector(p.right, (u - j.cx) / j.fx * depth)
    .addScaledVector(p.down, (v - j.cy) / j.fy * depth)
    .addScaledVector(p.forward, depth);
  const a = corner(0, 0), b = corner(j.width, 0), c = corner(j.width, j.height), d = corner(0, j.height);
  const o = p.centre;
  return [o, a, o, b, o, c, o, d, a, b, b, c, c, d, d, a];
}

function frusta(cameras, depth, color) {
  const points = [];
  for (const c of cameras) points.push(...frustum(c.camera, depth));
  const geometry = new THREE.BufferGeometry().setFromPoints(points);
  return new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ color }));
}

function frame() {
  return new Promise((resolve) => requestAnimationFrame(resolve));
}

async function main() {
  const scene = await loadScene();
  const extras = scene.extras;
  const training = extras.cameras?.training ?? [];
  const expanded = extras.cameras?.expanded ?? [];
  const times = scene.header.num_times;

  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(innerWidth, innerHeight);
  document.body.appendChild(renderer.domElement);
  const world = new THREE.Scene();
  const spark = new SparkRenderer({
    renderer, preBlurAmount: kLowPass, blurAmount: 0, maxStdDev: kMaxStdDev,
    minAlpha: kMinAlpha, sortRadial: false, enableLod: false,
  });
  world.add(spark);
  const statics = new SplatMesh({ packedSplats: staticSplats(scene.statics) });
  const dynamic = new DynamicSplats(scene);
  const dynamics = new SplatMesh({ packedSplats: dynamic.packed });
  world.add(statics, dynamics);
  await Promise.all([statics.initialized, dynamics.initialized]);
  statics.visible = scene.statics.count > 0;
  dynamics.visible = scene.dynamics.count > 0;

  // Helpers: frusta a twentieth of the scene's extent deep, the centre.
  const extent = extras.extent ?? 1;
  const trainingFrusta = frusta(training, 0.05 * extent, 0x44aaff);
  const expandedFrusta = frusta(expanded, 0.05 * extent, 0xffaa33);
  expandedFrusta.visible = false;
  const centre = new THREE.Vector3(...(extras.centre ?? [0, 0, 0]));
  const centreMark = new THREE.AxesHelper(0.05 * extent);
  centreMark.position.copy(centre);
  world.add(trainingFrusta, expandedFrusta, centreMark);

  // The free camera starts at the middle training camera, orbiting the
  // centre, with the capture's up (extras.up).
  const camera = new THREE.PerspectiveCamera(50, innerWidth / innerHeight, kNearPlane * extent, 1000 * extent);
  if (extras.up) camera.up.set(...extras.up);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(centre);
  let fixed = null;  // a camera of the capture, with its own projection

  function applyCamera(j) {
    const p = cameraPose(j);
    camera.position.copy(p.centre);
    camera.quaternion.copy(p.quaternion);
    camera.updateMatrixWorld(true);
    fixed = j;
  }
  function resize() {
    const w = fixed && capturing ? fixed.width : innerWidth;
    const h = fixed && capturing ? fixed.height : innerHeight;
    renderer.setSize(w, h);
    if (fixed) {
      // The camera's own intrinsics, scaled to the window (same aspect
      // when capturing).
      const s = Math.min(w / fixed.width, h / fixed.height);
      const j = { ...fixed, width: w, height: h, fx: fixed.fx * s, fy: fixed.fy * s,
                  cx: fixed.cx * s + (w - fixed.width * s) / 2, cy: fixed.cy * s + (h - fixed.height * s) / 2 };
      camera.projectionMatrix.copy(projection(j, camera.near, camera.far));
      camera.projectionMatrixInverse.copy(camera.projectionMatrix).invert();
    } else {
      camera.aspect = w / h;
      camera.updateProjectionMatrix();
    }
  }
  function freeCamera() {
    if (fixed) camera.fov = 2 * Math.atan(fixed.height / (2 * fixed.fy)) * 180 / Math.PI;
    fixed = null;
    controls.enabled = true;
    controls.target.copy(centre);
    resize();
  }

  let time = Math.min(times - 1, scene.header.canonical_time);
  function setTime(t) {
    time = ((t % times) + times) % times;
    dynamic.pose(time, dynamics);
    $("time").value = time;
    $("time-label").textContent = `t ${time} / ${times - 1}`;
  }

  const capturing = params.has("capture");
  if (capturing) {
    document.body.classList.add("capture");
    await capture(params.get("capture"));
    return;
  }

  // The interactive page.
  $("time").max = times - 1;
  const middle = training[Math.floor(training.length / 2)];
  if (middle) { applyCamera(middle.camera); freeCamera(); }
  setTime(time);
  training.forEach((c, i) => $("view").add(new Option(`training ${c.name ?? i} (t ${c.t})`, `training:${i}`)));
  expanded.forEach((c, i) => $("view").add(new Option(`expanded ${i} (t ${c.t})`, `expanded:${i}`)));
  $("view").onchange = (e) => {
    const [kind, i] = e.target.value.split(":");
    if (kind === "free") return freeCamera();
    const c = (kind === "training" ? training : expanded)[Number(i)];
    applyCamera(c.camera);
    controls.enabled = false;
    setTime(c.t);
    resize();
  };
  let playing = false;
  const play = (on) => { playing = on; $("play").textContent = on ? "Pause" : "Play"; };
  $("play").onclick = () => play(!playing);
  $("time").oninput = (e) => { play(false); setTime(Number(e.target.value)); };
  const toggle = (id, object) => { $(id).onchange = (e) => { object.visible = e.target.checked; }; };
  toggle("show-static", statics);
  toggle("show-dynamic", dynamics);
  toggle("show-training", trainingFrusta);
  toggle("show-expanded", expandedFrusta);
  toggle("show-centre", centreMark);
  $("show-static").disabled = scene.statics.count === 0;
  $("show-dynamic").disabled = scene.dynamics.count === 0;
  addEventListener("resize", resize);

  // Fly: W A S D along the view, Q E down and up; the orbit target moves
  // along, so that orbiting continues from where one flew to.
  const keys = new Set();
  addEventListener("keydown", (e) => {
    if (e.target.tagName === "INPUT" && e.target.type === "range") return;
    if (e.code === "Space") { play(!playing); e.preventDefault(); }
    keys.add(e.code);
  });
  addEventListener("keyup", (e) => keys.delete(e.code));
  let last = performance.now(), lastStep = last, frames = 0, fpsStart = last, fps = 0;
  renderer.setAnimationLoop(() => {
    const now = performance.now(), dt = (now - last) / 1000;
    last = now;
    const forward = new THREE.Vector3(), right = new THREE.Vector3();
    camera.getWorldDirection(forward);
    right.crossVectors(forward, camera.up).normalize();
    const move = new THREE.Vector3();
    const speed = 0.3 * extent * dt;
    if (keys.has("KeyW")) move.addScaledVector(forward, speed);
    if (keys.has("KeyS")) move.addScaledVector(forward, -speed);
    if (keys.has("KeyD")) move.addScaledVector(right, speed);
    if (keys.has("KeyA")) move.addScaledVector(right, -speed);
    if (keys.has("KeyE")) move.addScaledVector(camera.up, speed);
    if (keys.has("KeyQ")) move.addScaledVector(camera.up, -speed);
    if (move.lengthSq() > 0) {
      if (fixed) freeCamera(), ($("view").value = "free");
      camera.position.add(move);
      controls.target.add(move);
    }
    if (playing && now - lastStep >= 1000 / kPlayFps) { lastStep = now; setTime(time + 1); }
    if (!fixed) controls.update();
    renderer.render(world, camera);
    if (++frames === 30) { fps = 30000 / (now - fpsStart); frames = 0; fpsStart = now; }
    $("status").textContent =
      `${scene.statics.count} static + ${scene.dynamics.count} dynamic Gaussians, ` +
      `${times} times, ${scene.bases.count} motion bases\n${fps.toFixed(1)} frames/s`;
  });

  async function capture(file) {
    const post = (name, body) => fetch(`/capture/${name}`, { method: "POST", body });
    try {
      const list = await (await fetch(file)).json();
      for (const h of [trainingFrusta, expandedFrusta, centreMark]) h.visible = false;
      for (const shot of list) {
        applyCamera(shot.camera);
        resize();
        setTime(shot.t);
        // Spark sorts in a worker: render until a sort of this view is done.
        for (let i = 0; i < 200; ++i) {
          renderer.render(world, camera);
          await frame();
          if (i >= 8 && !spark.sorting && !spark.sortDirty) break;
        }
        renderer.render(world, camera);
        const blob = await new Promise((r) => renderer.domElement.toBlob(r, "image/png"));
        await post(`${shot.name}.png`, blob);
      }
      // Frame rate: a still view, then playing (every frame a new time),
      // each over 5 s or 60 frames, whichever comes first (software WebGL
      // on a large scene draws well under a frame a second).
      const measure = async (playingTimes) => {
        const start = performance.now();
        let count = 0;
        while (count < 60 && (count < 3 || performance.now() - start < 5000)) {
          if (playingTimes) setTime(time + 1);
          renderer.render(world, camera);
          await frame();
          ++count;
        }
        return count * 1000 / (performance.now() - start);
      };
      const still = await measure(false), played = await measure(true);
      await post("done.json", JSON.stringify({
        fps_still: still, fps_playing: played, width: renderer.domElement.width,
        height: renderer.domElement.height, webgl: rendererName(renderer),
        gaussians: scene.statics.count + scene.dynamics.count,
      }));
    } catch (e) {
      await post("error.json", JSON.stringify({ error: String(e), stack: e.stack }));
    }
  }
}

function rendererName(renderer) {
  const gl = renderer.getContext();
  const info = gl.getExtension("WEBGL_debug_renderer_info");
  return info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
}

main().then(() => console.log("pano4d viewer ready")).catch((e) => {
  console.error("pano4d viewer failed: " + e);
  $("error").textContent = `${e}`;
  if (params.has("capture"))
    fetch("/capture/error.json", { method: "POST", body: JSON.stringify({ error: String(e), stack: e.stack }) });
});
