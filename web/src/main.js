// homcull viewer: loads a scene's GLB with three.js, streams the camera pose to the
// server and draws exactly the visible set the server answers.

import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

import { HomcullClient, State } from "./client.js";
import {
  LOCKSTEP_ENTER_MS,
  LOCKSTEP_LEAVE_MS,
  REGION,
  RateMeter,
  ViewLog,
  parseDisplayMode,
  regionHolds,
  regionMargin,
  useLockstep,
} from "./display.js";
import { flatten, mapObjects, walkStart } from "./scene-map.js";
import { fetchJson, loadGlb } from "./loading.js";
import { debugMaterials, levelMaterial, prepareMaterials } from "./materials.js";

const EYE_HEIGHT = 1.7;
const WALK_SPEED = 5; // m/s; Shift runs at 4x
const TURN_SPEED = 1.6; // rad/s with the arrow keys
const LOOK_SENSITIVITY = 0.0025; // rad per pixel
const NEAR = 0.1;
const DEFAULT_FAR = 5000;

const $ = (id) => document.getElementById(id);
const query = new URLSearchParams(location.search);

// app.js is running: the boot panel's "app.js did not load" hint no longer applies.
for (const el of document.querySelectorAll("#boot .hint")) el.hidden = true;

// --- errors shown in the page --------------------------------------------------------

const errorBox = $("errors");
const shownErrors = new Map();

/** Shows `message` in the page (replacing an earlier one with the same key). */
function showError(key, message, { warn = false, log = true } = {}) {
  let el = shownErrors.get(key);
  if (!el) {
    el = document.createElement("div");
    el.className = "error";
    el.dataset.key = key;
    const text = document.createElement("span");
    const close = document.createElement("button");
    close.type = "button";
    close.setAttribute("aria-label", "dismiss");
    close.textContent = "\u00d7";
    close.onclick = () => clearError(key);
    el.append(text, close);
    errorBox.append(el);
    shownErrors.set(key, el);
  }
  el.classList.toggle("warn", warn);
  el.firstChild.textContent = message;
  if (log) (warn ? console.warn : console.error)(`homcull: ${message}`);
}

function clearError(key) {
  shownErrors.get(key)?.remove();
  shownErrors.delete(key);
}

// --- three.js setup ------------------------------------------------------------------

const canvas = $("view");
let renderer;
try {
  renderer = new THREE.WebGLRenderer({ canvas, antialias: true, powerPreference: "high-performance" });
} catch (e) {
  renderer = null;
  $("boot-message").textContent = `WebGL is not available in this browser (${e.message}).`;
  showError("webgl", `WebGL is not available in this browser: ${e.message}`);
}
if (renderer) renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));

const scene3 = new THREE.Scene();
const SKY = new THREE.Color(0x9cc3e6);
scene3.background = SKY;
scene3.add(new THREE.HemisphereLight(0xdde8f5, 0x6b6357, 1.5));
const sun = new THREE.DirectionalLight(0xfff4e0, 1.1);
sun.position.set(-0.45, 1, 0.3);
scene3.add(sun);

const camera = new THREE.PerspectiveCamera(60, 16 / 9, NEAR, DEFAULT_FAR);
camera.rotation.order = "YXZ";
scene3.add(camera);

// Lockstep display (display.js): the camera of the pose the drawn set answers.
const answeredCamera = new THREE.PerspectiveCamera(60, 16 / 9, NEAR, DEFAULT_FAR);
const eyeCamera = new THREE.PerspectiveCamera(60, 16 / 9, NEAR, DEFAULT_FAR);

const overviewCamera = new THREE.PerspectiveCamera(50, 16 / 9, 1, 20000);
const frustumProxy = new THREE.PerspectiveCamera(60, 16 / 9, NEAR, 60);
const frustumHelper = new THREE.CameraHelper(frustumProxy);
frustumHelper.visible = false;
scene3.add(frustumHelper);

const objectsRoot = new THREE.Group();
objectsRoot.name = "homcull objects";
scene3.add(objectsRoot);

const controls = new OrbitControls(camera, canvas);
controls.enabled = false;
controls.enableDamping = false;

// --- app state -----------------------------------------------------------------------

const app = {
  sceneId: null,
  sceneInfo: null,
  objects: [], // object table rows
  triangles: new Uint32Array(0),
  meshesById: [],
  groundY: 0,
  mode: "walk",
  yaw: 0,
  pitch: 0,
  keys: new Set(),
  dragging: null,
  culling: query.get("culling") !== "off",
  debug: query.get("debug") === "1",
  overview: query.get("overview") === "1",
  client: null,
  latest: null, // last 'visible' event detail + mask
  placed: new Map(), // object id → the placement (column-major 4×4) last applied
  latestVersion: 0,
  appliedVersion: -1,
  appliedKey: "",
  rendered: null, // {ack, ids, levels, stats, view, lockstep} of the last rendered frame
  // Display mode (display.js, `?display=region|auto|lockstep|predict`) and whether frames
  // are drawn in lockstep now; the views of the poses sent, until answered.
  display: parseDisplayMode(query.get("display")),
  // Region streams (display "region"): the region announced for the next set, the region
  // of the set held (with the view of the pose it was culled for), whether the drawn
  // eyes lie in it, and region frames per second.
  pendingRegion: null,
  heldRegion: null,
  guaranteed: false,
  regionRate: new RateMeter(),
  lockstep: query.get("display") === "lockstep",
  views: new ViewLog(),
  sendingExact: false, // the pose last given to the client is the drawn view itself
  lastPose: null, // {seq, position, rotation, fov_y_deg, viewport, near, far} last sent
  drawnCount: 0,
  drawnTriangles: 0,
  fps: 0,
  frameTimes: [],
  debugGroup: null,
  stereo: query.get("stereo") === "1", // side-by-side stereo view (key V)
  eyes: [], // the eye positions of the last stereo frame drawn
  tint: new Map(), // id → level of the drawn objects the debug view tints by level
  lodSkipped: null, // triangles coarser levels would skip in the drawn set (null: no levels)
  // Debug view: the occluders the server renders for a recent pose (POST …/occluders).
  frameOccluders: new Set(),
  occludersVersion: 0,
  loaded: false,
};

let resolveReady;
let rejectReady;
const ready = new Promise((res, rej) => {
  resolveReady = res;
  rejectReady = rej;
});
ready.catch(() => {}); // reported in the page; tests await it themselves

async function start() {
  if (!renderer) {
    rejectReady(new Error("WebGL is not available"));
    return;
  }
  const bootMessage = $("boot-message");
  try {
    const list = await fetchJson("/v1/scenes", "scene list");
    const scenes = list.scenes ?? [];
    const select = $("scene-select");
    for (const s of scenes) {
      const opt = document.createElement("option");
      opt.value = s.id;
      opt.textContent = `${s.name || s.id} (${s.objects.toLocaleString("en-US")} objects)`;
      select.append(opt);
    }
    select.onchange = () => {
      const q = new URLSearchParams(location.search);
      q.set("scene", select.value);
      location.search = q.toString();
    };
    const wanted = query.get("scene");
    const info = wanted ? scenes.find((s) => s.id === wanted) : (scenes.find((s) => s.id === "demo") ?? scenes[0]);
    if (!info) {
      throw new Error(wanted ? `unknown scene "${wanted}": this server has ${scenes.map((s) => s.id).join(", ") || "no scenes"}` : "this server has no scenes yet: upload a GLB with POST /v1/scenes");
    }
    select.value = info.id;
    app.sceneId = info.id;
    app.sceneInfo = info;
    for (const w of info.warnings ?? []) showError(`warn:${w}`, `scene ${info.id}: ${w}`, { warn: true, log: false });
    bootMessage.textContent = `Loading ${info.name || info.id}\u2026`;

    const objectsPromise = fetchJson(`/v1/scenes/${encodeURIComponent(info.id)}/objects`, "object table");
    const mb = (n) => (n / 1048576).toFixed(1);
    const gltf = await loadGlb(`/v1/scenes/${encodeURIComponent(info.id)}/glb`, (got, total) => {
      bootMessage.textContent = `Loading ${info.name || info.id}: ${mb(got)} / ${mb(total)} MB`;
    });
    const { objects } = await objectsPromise;
    app.objects = objects;
    app.triangles = Uint32Array.from(objects, (o) => o.triangles);

    const { meshesById, warnings } = mapObjects(gltf);
    for (const w of warnings) console.warn(`homcull: ${w}`);
    if (meshesById.length !== objects.length) {
      throw new Error(
        `the scene GLB has ${meshesById.length} mesh nodes but the server lists ${objects.length} objects: object IDs cannot be mapped to meshes`,
      );
    }
    prepareMaterials(gltf, meshesById, app.objects);
    flatten(gltf.scene, meshesById, objectsRoot);
    app.meshesById = meshesById;
    for (const meshes of meshesById) for (const m of meshes) m.visible = false;

    const [lo, hi] = info.bounds;
    app.groundY = lo[1];
    const diag = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    camera.far = Math.min(Math.max(DEFAULT_FAR, diag * 2), NEAR * 1e7);
    camera.updateProjectionMatrix();
    scene3.fog = new THREE.Fog(SKY, Math.max(200, diag * 0.25), Math.max(1500, diag * 1.5));
    startPose(info);

    $("boot").hidden = true;
    $("toolbar").hidden = false;
    $("hud").hidden = false;
    $("help").hidden = false;
    setHud("hud-objects-total", objects.length, fmtInt);
    setHud("hud-triangles-total", info.triangles ?? app.triangles.reduce((a, b) => a + b, 0), fmtInt);
    app.loaded = true;
    connect(info.id);
  } catch (e) {
    bootMessage.textContent = e.message;
    showError("load", e.message);
    const select = $("scene-select");
    if (select.options.length) {
      // Let the user pick another scene.
      if (!app.sceneId) select.selectedIndex = -1;
      $("toolbar").hidden = false;
    }
    rejectReady(e);
  }
}

function startPose(info) {
  if (info.id === "demo") {
    // The demo city's origin is on an open street crossing; look east along the street.
    setWalkPose([0, EYE_HEIGHT, 0], -90, 0);
    return;
  }
  // Other scenes: at street level where the server found open ground, else from above.
  const start = walkStart(info);
  if (start) {
    setWalkPose(start.position, start.yawDeg, 0);
    return;
  }
  const [lo, hi] = info.bounds;
  const c = new THREE.Vector3((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2);
  const r = Math.max(1, Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) / 2);
  setMode("orbit");
  camera.position.set(c.x + r * 0.9, c.y + r * 0.7, c.z + r * 0.9);
  controls.target.copy(c);
  controls.update();
}

// --- streaming -----------------------------------------------------------------------

/**
 * Stream smoothing the viewer asks for (see the server's stream options): the server also
 * culls the pose 150 ms ahead along the walk, so that what walking reveals is in the set
 * before the camera gets there, and keeps objects for 300 ms after their last sighting,
 * so that tiny distant objects do not flicker. `?lookahead_ms=0&hold_ms=0` turns both off
 * (then the drawn set is exactly `POST /cull`'s for the pose sent).
 */
export const SMOOTHING = { lookahead_ms: 150, hold_ms: 300 };

/**
 * The viewer streams HOM's box test without the per-pixel refinement (`refine=false`;
 * `?refine=true` turns it on). The refinement is exact for the pose sent, so a camera
 * that has moved on by the time the set is drawn sees slivers it reveals one round trip
 * late (measured in Chromium at 13 frames/s: 3–6 % of the oracle's sightings); the box
 * test's slack covers that motion (0–0.2 %). It is also the server's default for
 * streams; REST and batch clients get the refinement.
 */
export const STREAM_OPTIONS = { refine: false };

/**
 * Level-of-detail thresholds the viewer asks for (pixels, largest first; `?lod_px=` sets
 * others, `?lod_px=off` none): every visible object then comes with a level, 0 at 256
 * pixels or more on screen, 1 from 64, 2 from 16, 3 below. The viewer draws every
 * object at full detail, but the debug view tints objects by level and the HUD shows
 * what a client drawing coarser levels would skip (`lodSkippedTriangles`).
 */
export const LOD_PX = "256,64,16";

/**
 * Distance between the eyes of the side-by-side stereo view (`?stereo=1`, key V), metres.
 * The viewer then sends stereo poses (both eyes in one query, parallel optical axes)
 * culled at one eye's viewport, half the canvas, and draws the one answer twice, each
 * half of the canvas from its eye.
 */
export const STEREO_IPD_M = 0.064;

/**
 * Triangles a client would skip drawing objects at their levels instead of in full, if
 * each level had a quarter of the triangles of the one before (halving the detail along
 * both screen axes): `sum over visible objects of triangles × (1 − 4^−level)`.
 */
export function lodSkippedTriangles(ids, levels, triangles) {
  let skipped = 0;
  ids.forEach((id, k) => {
    skipped += (triangles[id] ?? 0) * (1 - 4 ** -(levels[k] ?? 0));
  });
  return Math.round(skipped);
}

/**
 * Moves objects where the server's writers put them: each `{id, matrix}` is a
 * column-major 4×4 relative to the scene file, applied to the meshes drawing the
 * object (whose own matrices, after `flatten`, are their world matrices as loaded).
 */
function applyPlacements(objects) {
  for (const { id, matrix } of objects) {
    const meshes = app.meshesById[id];
    if (!meshes || !Array.isArray(matrix) || matrix.length !== 16) continue;
    const placement = new THREE.Matrix4().fromArray(matrix);
    for (const m of meshes) {
      if (!m.userData.loadedMatrix) m.userData.loadedMatrix = m.matrix.clone();
      m.matrix.multiplyMatrices(placement, m.userData.loadedMatrix);
      m.matrix.decompose(m.position, m.quaternion, m.scale);
      m.matrixWorldNeedsUpdate = true;
    }
    app.placed.set(id, matrix);
  }
}

/** Whether the viewer streams regions (display "region"; fixed for the page). */
function regionStream() {
  return app.display === "region";
}

function connect(sceneId) {
  // Told where moved objects are (scene version and placements, before the frames). A
  // region stream takes no point smoothing: its sets hold for the whole region.
  const region = { region_m: query.get("region_m") ?? REGION.region_m, turn_deg: query.get("turn_deg") ?? REGION.turn_deg };
  const params = regionStream() ? { ...STREAM_OPTIONS, ...region, placements: true } : { ...STREAM_OPTIONS, ...SMOOTHING, placements: true };
  const keys = ["method", "threshold", "deb", "refine", "seen_first", ...(regionStream() ? [] : ["lookahead_ms", "hold_ms"])];
  for (const k of keys) if (query.has(k)) params[k] = query.get(k);
  const lod = query.get("lod_px") ?? LOD_PX;
  if (lod !== "" && lod !== "off") params.lod_px = lod;
  const client = new HomcullClient({ url: location.origin, scene: sceneId, params });
  app.client = client;
  client.addEventListener("state", (e) => {
    const { state, delayMs } = e.detail;
    const label = state === State.RECONNECTING && delayMs !== undefined ? `reconnecting in ${(delayMs / 1000).toFixed(1)} s` : state;
    setHud("hud-state", state, () => label);
    if (state === State.OPEN) clearError("connection");
  });
  client.addEventListener("hello", (e) => {
    const { info, objectCount } = e.detail;
    const adapter = `${info.adapter ?? "unknown adapter"}${info.cpu_fallback ? " (CPU fallback)" : ""}`;
    setHud("hud-adapter", adapter, (v) => v);
    $("hud-adapter").title = adapter;
    setHud("hud-backend", info.backend ?? "", backendLabel);
    // A new stream: no region is held until it sends one.
    app.pendingRegion = null;
    app.heldRegion = null;
    if (objectCount !== app.objects.length) {
      showError("mismatch", `the stream reports ${objectCount} objects but the object table has ${app.objects.length}; reload the page`);
    }
  });
  client.addEventListener("placements", (e) => applyPlacements(e.detail.objects));
  client.addEventListener("region", (e) => {
    app.pendingRegion = e.detail;
    app.regionRate.add(performance.now());
  });
  client.addEventListener("pose", (e) => {
    const { seq, pose, wantFull } = e.detail;
    app.lastPose = { seq, wantFull, ...pose };
    app.views.record(seq, { ...pose, exact: app.sendingExact });
  });
  client.addEventListener("visible", (e) => {
    const d = e.detail;
    const mask = new Uint8Array(app.meshesById.length);
    for (const id of d.ids) if (id < mask.length) mask[id] = 1;
    const levels = client.visible.levels ? d.ids.map((id) => client.visible.level(id)) : null;
    app.latest = { ack: d.ack, ids: d.ids, levels, stats: d.stats, mask, view: app.views.answer(d.ack) };
    // A region frame holds for the set that follows it.
    if (app.pendingRegion) {
      app.heldRegion = { ...app.pendingRegion, view: app.latest.view };
      app.pendingRegion = null;
    }
    app.latestVersion += 1;
    if (d.ids.length && d.ids[d.ids.length - 1] >= mask.length) {
      showError("range", `the server sent object ID ${d.ids[d.ids.length - 1]}, beyond the ${mask.length} objects of the scene`);
    }
  });
  client.addEventListener("error", (e) => {
    const { code, message, fatal } = e.detail;
    const key = code === "connection" ? "connection" : `stream:${code}`;
    showError(key, fatal ? `${message} (the viewer stopped streaming; reload to retry)` : message, {
      warn: !fatal && code !== "protocol" && code !== "bad_delta",
    });
  });
  client.connect();
}

/**
 * Degrees the guard band adds to the vertical field of view of the pose
 * sent for culling. The server culls a slightly wider view than the page draws, from the
 * same eye, so that turning does not pop objects in at the screen's edge while the
 * answer for the new pose is on its way (a wider view from the same eye only adds
 * objects: culling stays conservative for what is drawn).
 */
export const GUARD_FOV_DEG = 10;

/**
 * The culled view for a canvas of `w` × `h` pixels drawn with vertical fov `fovDeg`:
 * the fov widened by GUARD_FOV_DEG and the viewport grown by the same ratio, so the
 * pixel density stays the drawn image's. (Aligning the two pixel grids exactly, whole
 * pixels per side, measured worse for the box test in the walking e2e: 17–25 late
 * sightings in ~2,500 against 0–5, so it is not done.)
 */
export function guardBand(w, h, fovDeg) {
  const fov = Math.min(fovDeg + GUARD_FOV_DEG, 170);
  const grow = Math.tan((fov * Math.PI) / 360) / Math.tan((fovDeg * Math.PI) / 360);
  return { fov, viewport: [Math.round(w * grow), Math.round(h * grow)] };
}

/**
 * The pose to cull for the controls' camera: the drawn view itself in lockstep (the set
 * is drawn with this very view) and on region streams (the region covers the motion),
 * else widened by the guard band. A region stream is sent the centre between the eyes
 * in stereo, with one eye's viewport: both eyes look that way with that frustum from
 * within STEREO_IPD_M / 2 of it, so the one region that holds them is one answer.
 */
function currentPose() {
  const [w, h] = eyeViewport();
  app.sendingExact = app.lockstep || regionStream();
  const band = app.sendingExact ? { fov: camera.fov, viewport: [w, h] } : guardBand(w, h, camera.fov);
  return {
    position: camera.position.toArray(),
    rotation: camera.quaternion.toArray(),
    fov_y_deg: band.fov,
    viewport: band.viewport,
    near: camera.near,
    far: camera.far,
    ...(app.stereo && !regionStream() ? { stereo: { ipd_m: STEREO_IPD_M } } : {}),
  };
}

/**
 * Whether the region of the set held holds every eye drawn now: its ball and cone, and
 * the frustum shape it was culled for (a resized canvas asks for another region).
 */
function eyesInHeldRegion() {
  const held = app.heldRegion;
  if (!held?.view) return false;
  const [w, h] = eyeViewport();
  if (held.view.viewport[0] !== w || held.view.viewport[1] !== h || Math.abs(held.view.fov_y_deg - camera.fov) > 1e-4) return false;
  const forward = new THREE.Vector3();
  camera.getWorldDirection(forward);
  const right = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0);
  const eyes = app.stereo ? [-0.5, 0.5].map((side) => camera.position.clone().addScaledVector(right, side * STEREO_IPD_M)) : [camera.position];
  return eyes.every((eye) => regionHolds(held, eye.toArray(), forward.toArray()));
}

/** The viewport of one drawn eye: the canvas, or half of it side by side in stereo. */
function eyeViewport() {
  const w = Math.max(1, Math.round(canvas.clientWidth));
  const h = Math.max(1, Math.round(canvas.clientHeight));
  return [app.stereo ? Math.max(1, Math.round(w / 2)) : w, h];
}

// --- controls ------------------------------------------------------------------------

function setMode(mode) {
  if (mode === app.mode) return;
  if (mode === "orbit") {
    const fwd = new THREE.Vector3();
    camera.getWorldDirection(fwd);
    controls.target.copy(camera.position).addScaledVector(fwd, 30);
    if (document.pointerLockElement) document.exitPointerLock();
    controls.enabled = true;
    controls.update();
  } else {
    controls.enabled = false;
    const fwd = new THREE.Vector3();
    camera.getWorldDirection(fwd);
    app.yaw = Math.atan2(-fwd.x, -fwd.z);
    app.pitch = 0;
    camera.position.y = app.groundY + EYE_HEIGHT;
    applyWalkRotation();
  }
  app.mode = mode;
  $("mode-walk").setAttribute("aria-pressed", String(mode === "walk"));
  $("mode-orbit").setAttribute("aria-pressed", String(mode === "orbit"));
  $("help-walk").hidden = mode !== "walk";
  $("help-orbit").hidden = mode !== "orbit";
}

function applyWalkRotation() {
  app.pitch = Math.max(-Math.PI / 2 + 0.01, Math.min(Math.PI / 2 - 0.01, app.pitch));
  camera.rotation.set(app.pitch, app.yaw, 0, "YXZ");
  camera.updateMatrixWorld();
}

/** Puts the camera at `position`, turned `yawDeg` about +Y from −Z (−90 looks along +X), `pitchDeg` up. */
function setWalkPose(position, yawDeg = 0, pitchDeg = 0) {
  setMode("walk");
  camera.position.set(position[0], position[1], position[2]);
  app.yaw = THREE.MathUtils.degToRad(yawDeg);
  app.pitch = THREE.MathUtils.degToRad(pitchDeg);
  applyWalkRotation();
}

function updateWalk(dt) {
  const k = app.keys;
  const turn = (k.has("ArrowLeft") ? 1 : 0) - (k.has("ArrowRight") ? 1 : 0);
  if (turn) {
    app.yaw += turn * TURN_SPEED * dt;
    applyWalkRotation();
  }
  const fwd = (k.has("KeyW") || k.has("ArrowUp") ? 1 : 0) - (k.has("KeyS") || k.has("ArrowDown") ? 1 : 0);
  const side = (k.has("KeyD") ? 1 : 0) - (k.has("KeyA") ? 1 : 0);
  if (!fwd && !side) return;
  const speed = WALK_SPEED * (k.has("ShiftLeft") || k.has("ShiftRight") ? 4 : 1);
  const dir = new THREE.Vector3(-Math.sin(app.yaw) * fwd + Math.cos(app.yaw) * side, 0, -Math.cos(app.yaw) * fwd - Math.sin(app.yaw) * side);
  if (dir.lengthSq() > 0) dir.normalize();
  camera.position.addScaledVector(dir, speed * dt);
}

const typing = (e) => e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement || e.target instanceof HTMLTextAreaElement;

window.addEventListener("keydown", (e) => {
  if (typing(e) || e.ctrlKey || e.metaKey || e.altKey) return;
  const single = {
    KeyM: () => setMode(app.mode === "walk" ? "orbit" : "walk"),
    KeyC: () => setCulling(!app.culling),
    KeyB: () => setDebug(!app.debug),
    KeyO: () => setOverview(!app.overview),
    KeyP: () => setPyramid($("pyramid").hidden),
    KeyV: () => setStereo(!app.stereo),
  }[e.code];
  if (single) {
    if (!e.repeat) single();
    return;
  }
  if (app.mode === "walk") {
    app.keys.add(e.code);
    if (e.code.startsWith("Arrow")) e.preventDefault();
  }
});
window.addEventListener("keyup", (e) => app.keys.delete(e.code));
window.addEventListener("blur", () => app.keys.clear());

canvas.addEventListener("click", () => {
  if (app.mode === "walk" && !document.pointerLockElement && canvas.requestPointerLock) {
    try {
      const p = canvas.requestPointerLock();
      if (p && p.catch) p.catch(() => {}); // refused (e.g. headless): dragging still works
    } catch {
      /* dragging still works */
    }
  }
});
canvas.addEventListener("pointerdown", (e) => {
  if (app.mode === "walk" && !document.pointerLockElement) app.dragging = { x: e.clientX, y: e.clientY };
});
window.addEventListener("pointerup", () => (app.dragging = null));
window.addEventListener("mousemove", (e) => {
  if (app.mode !== "walk") return;
  let dx = 0;
  let dy = 0;
  if (document.pointerLockElement === canvas) {
    dx = e.movementX;
    dy = e.movementY;
  } else if (app.dragging) {
    dx = e.clientX - app.dragging.x;
    dy = e.clientY - app.dragging.y;
    app.dragging = { x: e.clientX, y: e.clientY };
  } else return;
  app.yaw -= dx * LOOK_SENSITIVITY;
  app.pitch -= dy * LOOK_SENSITIVITY;
  applyWalkRotation();
});

$("mode-walk").onclick = () => setMode("walk");
$("mode-orbit").onclick = () => setMode("orbit");
$("culling-toggle").onchange = (e) => setCulling(e.target.checked);
$("debug-toggle").onchange = (e) => setDebug(e.target.checked);
$("overview-toggle").onchange = (e) => setOverview(e.target.checked);
$("pyramid-button").onclick = () => setPyramid($("pyramid").hidden);
$("stereo-toggle").onchange = (e) => setStereo(e.target.checked);

function setStereo(on) {
  app.stereo = on;
  $("stereo-toggle").checked = on;
}
$("pyramid-close").onclick = () => setPyramid(false);

function setCulling(on) {
  app.culling = on;
  $("culling-toggle").checked = on;
}

function setDebug(on) {
  app.debug = on;
  $("debug-toggle").checked = on;
  if (!on) setOverview(false);
}

function setOverview(on) {
  app.overview = on;
  $("overview-toggle").checked = on;
  if (on && !app.debug) setDebug(true);
}

$("culling-toggle").checked = app.culling;
$("debug-toggle").checked = app.debug;
$("overview-toggle").checked = app.overview;
$("stereo-toggle").checked = app.stereo;

// --- drawing the visible set ---------------------------------------------------------

/** Sets mesh.visible (and debug materials) from the latest visible set; cheap if unchanged. */
function applyVisibility() {
  const latest = app.latest;
  const key = `${app.culling}|${app.debug}|${app.occludersVersion}`;
  if (app.appliedVersion === app.latestVersion && app.appliedKey === key) return;
  app.appliedVersion = app.latestVersion;
  app.appliedKey = key;
  const mask = latest?.mask;
  let count = 0;
  let tris = 0;
  const wires = app.debug ? ensureDebugGroup() : null;
  const levelOf = new Map((latest?.levels ?? []).map((level, k) => [latest.ids[k], level]));
  app.tint.clear();
  app.meshesById.forEach((meshes, id) => {
    const visible = app.culling ? Boolean(mask && mask[id]) : true;
    if (visible) {
      count += 1;
      tris += app.triangles[id];
    }
    // Debug view: occluders blue, other objects white; with levels of detail, each
    // tinted by its level (occluders in shades of blue).
    let material = null;
    const occluder = app.frameOccluders.has(id);
    if (app.debug && levelOf.has(id)) {
      material = levelMaterial(levelOf.get(id), occluder);
      if (visible) app.tint.set(id, levelOf.get(id));
    } else if (app.debug) material = occluder ? debugMaterials.occluder : debugMaterials.drawn;
    for (const m of meshes) {
      m.visible = visible;
      m.material = material ?? m.userData.homcullMaterial;
    }
    if (wires) for (const w of wires[id]) w.visible = !(mask && mask[id]);
  });
  if (app.debugGroup) app.debugGroup.visible = app.debug;
  app.drawnCount = count;
  app.drawnTriangles = tris;
  app.lodSkipped = latest?.levels && app.culling ? lodSkippedTriangles(latest.ids, latest.levels, app.triangles) : null;
}

function ensureDebugGroup() {
  if (app.debugGroup) return app.debugGroup.userData.byId;
  const group = new THREE.Group();
  group.name = "homcull culled (debug)";
  const byId = app.meshesById.map((meshes) =>
    meshes
      .filter((m) => m.isMesh)
      .map((m) => {
        const w = new THREE.Mesh(m.geometry, debugMaterials.culled);
        w.matrixAutoUpdate = false;
        w.matrix.copy(m.matrixWorld);
        w.renderOrder = 1;
        group.add(w);
        return w;
      }),
  );
  group.userData.byId = byId;
  group.updateMatrixWorld(true);
  scene3.add(group);
  app.debugGroup = group;
  return byId;
}

// --- HUD -----------------------------------------------------------------------------

const fmtInt = (v) => Number(v).toLocaleString("en-US");
const fmtMs = (v) => (Number.isFinite(v) ? v.toFixed(1) : "\u2013");

/** Shows `format(value)` in HUD element `id`, keeping the raw value in `data-value`. */
/** The HUD's name for the backend that answers (`/readyz` and the hello's `backend`). */
function backendLabel(backend) {
  switch (backend) {
    case "gpu":
      return "GPU";
    case "cpu":
      return "native CPU";
    case "reference":
      return "CPU reference";
    default:
      return backend || "\u2013";
  }
}

function setHud(id, value, format) {
  const el = $(id);
  const raw = String(value);
  const text = format(value);
  if (el.dataset.value !== raw) el.dataset.value = raw;
  if (el.textContent !== text) el.textContent = text;
}

function updateHud() {
  const frame = app.rendered;
  const total = app.objects.length;
  setHud("hud-objects-drawn", app.drawnCount, fmtInt);
  setHud("hud-triangles-drawn", app.drawnTriangles, fmtInt);
  setHud("hud-lod-skipped", app.lodSkipped ?? "", (v) => (v === "" ? "\u2013" : fmtInt(v)));
  $("hud-lod-skipped-pct").textContent =
    app.lodSkipped !== null && app.drawnTriangles ? `(${((100 * app.lodSkipped) / app.drawnTriangles).toFixed(0)} % of those drawn)` : "";
  if (frame) {
    const s = frame.stats;
    const pct = (n) => (s.objects ? `(${((100 * n) / s.objects).toFixed(0)} %)` : "");
    setHud("hud-objects-total", s.objects, fmtInt);
    setHud("hud-culled-frustum", s.culled_by_frustum, fmtInt);
    setHud("hud-culled-occlusion", s.culled_by_occlusion, fmtInt);
    $("hud-culled-frustum-pct").textContent = pct(s.culled_by_frustum);
    $("hud-culled-occlusion-pct").textContent = s.candidates
      ? `(${((100 * s.culled_by_occlusion) / s.candidates).toFixed(0)} % of those in view)`
      : "";
    setHud("hud-cull-ms", s.total_us / 1000, fmtMs);
    setHud("hud-gpu-ms", s.gpu_us / 1000, fmtMs);
  } else {
    setHud("hud-objects-total", total, fmtInt);
  }
  if (app.client) {
    const r = app.client.rtt();
    setHud("hud-rtt-p50", Number.isFinite(r.p50) ? r.p50 : "", (v) => (v === "" ? "\u2013" : fmtMs(v)));
    setHud("hud-rtt-p95", Number.isFinite(r.p95) ? r.p95 : "", (v) => (v === "" ? "\u2013" : fmtMs(v)));
  }
  setHud("hud-fps", app.fps, (v) => String(v));
  const display = regionStream() ? "region" : app.lockstep ? "lockstep" : "predict";
  const spec = app.client?.hello?.info?.region;
  setHud("hud-display", display, (v) =>
    v === "region" && spec ? `region ${spec.radius_m} m, ${spec.turn_deg}°` : app.display === "auto" ? `${v} (auto)` : v,
  );
  if (regionStream()) {
    const held = app.heldRegion;
    const margin = held ? regionMargin(held, camera.position.toArray()) : NaN;
    setHud("hud-region", app.guaranteed ? margin.toFixed(2) : "outside", (v) =>
      v === "outside" ? "not guaranteed: outside the held region" : `inside, ${v} m to its edge`,
    );
    setHud("hud-region-rate", app.regionRate.rate(performance.now()), (v) => v.toFixed(0));
  }
  $("hud-region-row").hidden = !regionStream();
  $("hud-display").title =
    "region: the current camera is drawn at once with the set of the region it holds (nothing it shows is missing while the camera stays inside). " +
    "lockstep: each visible set is drawn with the view of the pose it answers (nothing pops; the view lags by one round trip). " +
    "predict: the latest set is drawn with the current camera (the guard band and smoothing cover the motion). " +
    `auto: lockstep while the round trip p50 is at most ${LOCKSTEP_ENTER_MS} ms (until it exceeds ${LOCKSTEP_LEAVE_MS} ms).`;
  const notes = [];
  if (!app.culling) notes.push("Culling is off: everything is drawn.");
  if (app.debug)
    notes.push(
      app.rendered?.levels
        ? "Debug view: this pose's occluders blue, other drawn objects by level of detail (0 white, 1 yellow, 2 orange, 3+ purple; occluders lighter blue with each level), culled objects red wireframe."
        : "Debug view: this pose's occluders blue, other drawn objects white, culled objects red wireframe.",
    );
  const note = notes.join(" ");
  if ($("hud-note").textContent !== note) $("hud-note").textContent = note;
}

// --- per-pose debug queries ------------------------------------------------------------

/**
 * Posts the last pose sent to `POST /v1/scenes/{id}/{path}`: one request at a time,
 * once per pose, at most every `q.intervalMs`. `onBody(body, seq)` takes the JSON
 * answer; a 404 other than `unknown_scene` marks the route unavailable (an older
 * server) and calls `q.onUnavailable`; failures call `q.onError` and show in the page.
 */
async function queryPose(q, path, onBody) {
  if (q.busy || q.unavailable || !app.lastPose || !app.sceneId) return;
  if (q.lastSeq === app.lastPose.seq) return;
  const now = performance.now();
  if (now - q.lastAt < q.intervalMs) return;
  q.busy = true;
  q.lastAt = now;
  const { seq, position, rotation, fov_y_deg, viewport, near, far } = app.lastPose;
  try {
    const r = await fetch(`/v1/scenes/${encodeURIComponent(app.sceneId)}/${path}`, {
      method: "POST",
      headers: { "content-type": "application/json" },
      body: JSON.stringify({ pose: { position, rotation, fov_y_deg, viewport, near, far } }),
    });
    let body = null;
    try {
      body = await r.json();
    } catch {
      /* not JSON */
    }
    if (r.status === 404 && body?.error?.code !== "unknown_scene") {
      q.unavailable = true;
      q.onUnavailable?.();
      return;
    }
    if (!r.ok) throw new Error(body?.error?.message ?? `HTTP ${r.status}`);
    onBody(body, seq);
    q.lastSeq = seq;
    clearError(path);
  } catch (e) {
    q.onError?.(e);
    showError(path, `${path} request failed: ${e.message}`);
  } finally {
    q.busy = false;
  }
}

// What the server renders into the occlusion map changes with the pose (in-frustum
// occluders, nearest first, up to the triangle budget), so the debug view asks for it
// while it is on.
const occluderQuery = { busy: false, lastSeq: null, lastAt: 0, unavailable: false, intervalMs: 250 };

function refreshOccluders() {
  if (!app.debug) return;
  queryPose(occluderQuery, "occluders", (body) => {
    app.frameOccluders = new Set(body.occluders ?? []);
    app.occludersVersion += 1;
  });
}

// --- pyramid panel -------------------------------------------------------------------

const pyramid = {
  open: false,
  busy: false,
  lastSeq: null,
  lastAt: 0,
  unavailable: false,
  intervalMs: 500,
  onUnavailable() {
    $("pyramid-status").textContent = "pyramid view not available on this server";
    $("pyramid-levels").replaceChildren();
  },
  onError(e) {
    $("pyramid-status").textContent = `pyramid request failed: ${e.message}`;
  },
};

function setPyramid(open) {
  pyramid.open = open;
  $("pyramid").hidden = !open;
  $("pyramid-button").setAttribute("aria-pressed", String(open));
  if (open) {
    pyramid.lastSeq = null;
    refreshPyramid();
  }
}

function refreshPyramid() {
  if (!pyramid.open) return;
  queryPose(pyramid, "pyramid", (body, seq) => {
    const levels = body?.levels ?? [];
    const figs = levels.map((l) => {
      const fig = document.createElement("figure");
      const img = document.createElement("img");
      img.src = l.png;
      img.alt = `level ${l.level}`;
      const scale = Math.max(1, Math.min(4, Math.floor(256 / Math.max(1, l.width))));
      img.width = Math.min(l.width * scale, 320);
      img.height = Math.round((img.width * l.height) / Math.max(1, l.width));
      const cap = document.createElement("figcaption");
      cap.textContent = `level ${l.level}: ${l.width}\u00d7${l.height}`;
      fig.append(img, cap);
      return fig;
    });
    $("pyramid-levels").replaceChildren(...figs);
    $("pyramid-status").textContent = `${levels.length} levels for pose #${seq} (white = opaque)`;
  });
}

// --- render loop ---------------------------------------------------------------------

let lastTime = performance.now();
let firstFrameDone = false;

function resize() {
  const w = Math.max(1, canvas.clientWidth);
  const h = Math.max(1, canvas.clientHeight);
  const size = renderer.getSize(new THREE.Vector2());
  if (size.x !== w || size.y !== h) {
    renderer.setSize(w, h, false);
  }
  const [ew, eh] = eyeViewport();
  if (camera.aspect !== ew / eh) {
    camera.aspect = ew / eh;
    camera.updateProjectionMatrix();
  }
  overviewCamera.aspect = w / h;
  overviewCamera.updateProjectionMatrix();
}

function renderOverview() {
  const fwd = new THREE.Vector3();
  camera.getWorldDirection(fwd);
  fwd.y = 0;
  if (fwd.lengthSq() < 1e-6) fwd.set(0, 0, -1);
  fwd.normalize();
  const height = 220;
  overviewCamera.position.copy(camera.position).addScaledVector(fwd, -60).add(new THREE.Vector3(0, height, 0));
  overviewCamera.up.copy(fwd);
  overviewCamera.lookAt(camera.position.clone().addScaledVector(fwd, 60));
  frustumProxy.position.copy(camera.position);
  frustumProxy.quaternion.copy(camera.quaternion);
  frustumProxy.fov = camera.fov;
  frustumProxy.aspect = camera.aspect;
  frustumProxy.updateProjectionMatrix();
  frustumProxy.updateMatrixWorld();
  frustumHelper.update();
  frustumHelper.visible = true;
  renderer.render(scene3, overviewCamera);
  frustumHelper.visible = false;
}

function loop(now) {
  requestAnimationFrame(loop);
  const dt = Math.min(0.1, Math.max(0, (now - lastTime) / 1000));
  lastTime = now;
  resize();
  if (app.mode === "walk") updateWalk(dt);
  else controls.update();
  camera.updateMatrixWorld();
  if (app.client) app.lockstep = useLockstep(app.display, app.lockstep, app.client.rtt().p50);
  if (app.client && app.loaded) app.client.setPose(currentPose());
  applyVisibility();
  // Lockstep: draw the set with the view of the pose it answers (only a pose sent as the
  // drawn view itself, not one widened by the guard band).
  const answered = app.lockstep && app.latest?.view?.exact ? app.latest.view : null;
  const drawnCamera = answered ? cameraForView(answered) : camera;
  app.guaranteed = regionStream() && eyesInHeldRegion();
  if (app.overview) renderOverview();
  else if (app.stereo) renderStereo(drawnCamera);
  else renderer.render(scene3, drawnCamera);
  app.rendered = app.latest
    ? {
        ack: app.latest.ack,
        ids: app.latest.ids,
        levels: app.latest.levels,
        stats: app.latest.stats,
        view: viewOf(drawnCamera),
        lockstep: Boolean(answered),
        guaranteed: app.guaranteed,
      }
    : null;

  app.frameTimes.push(now);
  while (app.frameTimes.length && app.frameTimes[0] < now - 1000) app.frameTimes.shift();
  app.fps = app.frameTimes.length;
  updateHud();
  if (pyramid.open) refreshPyramid();
  if (app.debug) refreshOccluders();
  if (!firstFrameDone && app.rendered && app.loaded) {
    firstFrameDone = true;
    resolveReady({ scene: app.sceneId, ack: app.rendered.ack });
  }
}

/**
 * Draws the scene twice side by side, the left half from the left eye and the right
 * half from the right eye of `center` (`STEREO_IPD_M` apart along its right axis,
 * looking the same way), as the server culled them.
 */
function renderStereo(center) {
  const w = Math.max(1, Math.round(canvas.clientWidth));
  const h = Math.max(1, Math.round(canvas.clientHeight));
  const half = Math.max(1, Math.round(w / 2));
  app.eyes = [];
  renderer.setScissorTest(true);
  [-0.5, 0.5].forEach((side, k) => {
    eyeCamera.copy(center);
    eyeCamera.aspect = half / h;
    eyeCamera.translateX(side * STEREO_IPD_M);
    eyeCamera.updateProjectionMatrix();
    eyeCamera.updateMatrixWorld();
    renderer.setViewport(k * half, 0, half, h);
    renderer.setScissor(k * half, 0, half, h);
    renderer.render(scene3, eyeCamera);
    app.eyes.push(eyeCamera.position.toArray());
  });
  renderer.setScissorTest(false);
  renderer.setViewport(0, 0, w, h);
}

/** `answeredCamera` placed at a pose as sent ({position, rotation, fov_y_deg, viewport}). */
function cameraForView(view) {
  answeredCamera.position.fromArray(view.position);
  answeredCamera.quaternion.fromArray(view.rotation);
  answeredCamera.fov = view.fov_y_deg;
  answeredCamera.aspect = view.viewport[0] / view.viewport[1];
  answeredCamera.near = view.near ?? camera.near;
  answeredCamera.far = view.far ?? camera.far;
  answeredCamera.updateProjectionMatrix();
  answeredCamera.updateMatrixWorld();
  return answeredCamera;
}

/** The pose a camera draws this canvas with (what the exact oracle should be asked about). */
function viewOf(cam) {
  return {
    position: cam.position.toArray(),
    rotation: cam.quaternion.toArray(),
    fov_y_deg: cam.fov,
    viewport: eyeViewport(),
    near: cam.near,
    far: cam.far,
  };
}

// --- test and scripting hooks --------------------------------------------------------

function drawnIds() {
  const out = [];
  app.meshesById.forEach((meshes, id) => {
    if (meshes.some((m) => m.visible)) out.push(id);
  });
  return out;
}

function hud() {
  const num = (id) => {
    const v = $(id).dataset.value;
    return v === "" || v === undefined ? null : Number(v);
  };
  return {
    objectsDrawn: num("hud-objects-drawn"),
    objectsTotal: num("hud-objects-total"),
    trianglesDrawn: num("hud-triangles-drawn"),
    trianglesTotal: num("hud-triangles-total"),
    lodSkipped: num("hud-lod-skipped"),
    culledByFrustum: num("hud-culled-frustum"),
    culledByOcclusion: num("hud-culled-occlusion"),
    rttP50: num("hud-rtt-p50"),
    rttP95: num("hud-rtt-p95"),
    cullMs: num("hud-cull-ms"),
    fps: num("hud-fps"),
    state: $("hud-state").dataset.value,
    adapter: $("hud-adapter").dataset.value,
    backend: $("hud-backend").dataset.value,
    display: $("hud-display").dataset.value,
    // Region streams: metres inside the held region ("outside": not guaranteed), and
    // region frames in the last second.
    region: $("hud-region").dataset.value,
    regionsPerS: num("hud-region-rate"),
  };
}

window.homcull = {
  ready,
  /** Sorted IDs of the objects whose meshes were visible in the last rendered frame. */
  drawnIds,
  /**
   * {ack, ids, stats, view, lockstep, guaranteed} of the last rendered frame: the visible set drawn,
   * the view it was drawn with ({position, rotation, fov_y_deg, viewport, near, far}) and
   * whether that view is the answered pose's (lockstep) or the controls' camera.
   */
  get lastFrame() {
    return app.rendered;
  },
  /** The last pose sent to the server: {seq, wantFull, position, rotation, fov_y_deg, viewport, near, far}. */
  get lastPose() {
    return app.lastPose;
  },
  /** Moves the camera (walk mode): yaw about +Y from −Z in degrees (−90 looks along +X), pitch up. */
  setPose(position, yawDeg = 0, pitchDeg = 0) {
    setWalkPose(position, yawDeg, pitchDeg);
  },
  /** The HUD numbers as shown. */
  hud,
  /** The scene version the stream last named, and {id: matrix} of the placements applied. */
  get placements() {
    return { version: app.client?.sceneVersion ?? null, objects: Object.fromEntries(app.placed) };
  },
  /** World position of the first mesh drawing object `id` (three.js), or null. */
  objectPosition(id) {
    const m = app.meshesById[id]?.[0];
    if (!m) return null;
    m.updateMatrixWorld(true);
    const p = new THREE.Vector3().setFromMatrixPosition(m.matrixWorld);
    return [p.x, p.y, p.z];
  },
  /** {id: level} of the drawn objects the debug view tints by level of detail (occluders too). */
  tintedLevels() {
    return Object.fromEntries(app.tint);
  },
  /** Sorted IDs of the meshes the debug view paints as occluders. */
  occluderIds() {
    return [...app.frameOccluders].filter((id) => app.meshesById[id]).sort((a, b) => a - b);
  },
  setCulling,
  setDebug,
  setStereo,
  /** The eye positions the last stereo frame was drawn from (empty in mono). */
  get eyes() {
    return app.stereo ? app.eyes : [];
  },
  setOverview,
  setPyramid,
  setMode,
  get client() {
    return app.client;
  },
  get scene() {
    return app.sceneInfo;
  },
  three: { scene: scene3, camera, renderer },
};

if (renderer) requestAnimationFrame(loop);
start();
