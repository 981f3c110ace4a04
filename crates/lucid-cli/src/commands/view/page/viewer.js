// Lucid's viewer page: an orbit camera in the model's frame (+Z up), renders requested from
// the server one at a time (coarse while the camera moves, full resolution once it rests),
// the dataset's cameras drawn over the render, and comparisons with the dataset's images.
'use strict';

const $ = (id) => document.getElementById(id);
const canvas = $('render');
const overlay = $('overlay');
const truthCanvas = $('truth');

// How long the camera must rest before the full-resolution frame is asked for, and how long
// a coarse frame may take (its size adapts to the renderer's measured speed).
const REST_MS = 150;
const COARSE_SECONDS = 0.06;

let info = null;
const cam = { target: [0, 0, 0], yaw: 0, pitch: 0.5, dist: 4, fov: 40 };
const lens = { aperture: 0, focus: 4, rays: 16 };
const view = { depth: false, frustums: true, error: false, snapped: null, width: 200, height: 200 };

let version = 0;          // bumped by every change of what should be on screen
let lastChange = 0;       // when the camera last moved
let shown = { version: -1, full: false };
let inFlight = false;
let secondsPerPixel = 2e-6;
const frameTimes = [];
const frameLog = [];      // every frame shown: when, its size, render and round-trip seconds
let lastRender = { seconds: 0, width: 0, height: 0, samples: 0 };

// ---- vectors ------------------------------------------------------------------------------
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => scale(a, 1 / Math.hypot(a[0], a[1], a[2]));

// ---- the camera ---------------------------------------------------------------------------
function eye() {
  const c = Math.cos(cam.pitch);
  return add(cam.target, scale([c * Math.cos(cam.yaw), c * Math.sin(cam.yaw), Math.sin(cam.pitch)], cam.dist));
}

// Camera-to-world columns (right, up, back, position): the same construction as Lucid's look_at.
function basis() {
  const e = eye();
  const back = norm(sub(e, cam.target));
  const right = norm(cross([0, 0, 1], back));
  const up = cross(back, right);
  return { right, up, back, eye: e };
}

// The pose as the server reads it: 16 numbers, row-major.
function rowMajor(b) {
  return [b.right[0], b.up[0], b.back[0], b.eye[0],
          b.right[1], b.up[1], b.back[1], b.eye[1],
          b.right[2], b.up[2], b.back[2], b.eye[2], 0, 0, 0, 1];
}

function fromRowMajor(m) {
  return { right: [m[0], m[4], m[8]], up: [m[1], m[5], m[9]], back: [m[2], m[6], m[10]], eye: [m[3], m[7], m[11]] };
}

// The camera on screen: a snapped dataset camera exactly, else the orbit camera.
function currentCamera() {
  if (view.snapped) {
    const c = view.snapped;
    return { b: fromRowMajor(c.c2w), fov: c.fov_y_degrees, width: c.width, height: c.height };
  }
  return { b: basis(), fov: cam.fov, width: view.width, height: view.height };
}

// Puts the orbit camera where a pose is, looking at a point ahead of it (roll is dropped).
function orbitFrom(b) {
  const forward = scale(b.back, -1);
  const toCentre = sub(info.centre, b.eye);
  const d = Math.max(dot(toCentre, forward), 0.1 * info.radius);
  cam.target = add(b.eye, scale(forward, d));
  cam.dist = d;
  cam.pitch = Math.asin(Math.max(-1, Math.min(1, b.back[2])));
  cam.yaw = Math.atan2(b.back[1], b.back[0]);
}

function changed(moved) {
  version++;
  if (moved) lastChange = performance.now();
  drawOverlay();
}

function moveCamera(f) {
  if (view.snapped) unsnap(true);
  f();
  cam.pitch = Math.max(-1.55, Math.min(1.55, cam.pitch));
  changed(true);
}

function reset() {
  cam.target = info.centre.slice();
  cam.dist = info.radius;
  cam.yaw = 0.25 * Math.PI;
  cam.pitch = 0.45;
  cam.fov = info.fov_y_degrees;
  $('fov').value = cam.fov;
  unsnap(false);
  changed(true);
}

// ---- requests -----------------------------------------------------------------------------
function renderUrl(c, width, height, withLens, mode) {
  const q = new URLSearchParams({
    c2w: rowMajor(c.b).map((v) => v.toPrecision(9)).join(','),
    fov: c.fov.toPrecision(9), w: width, h: height, mode,
  });
  if (withLens && lens.aperture > 0) {
    q.set('aperture', lens.aperture);
    q.set('focus', lens.focus);
    q.set('lens_rays', lens.rays);
  }
  return '/api/render?' + q;
}

async function fetchImage(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${response.status}: ${await response.text()}`);
  const bitmap = await createImageBitmap(await response.blob());
  return { bitmap, headers: response.headers };
}

function draw(target, bitmap) {
  const g = target.getContext('2d');
  g.imageSmoothingEnabled = true;
  g.imageSmoothingQuality = 'high';
  g.drawImage(bitmap, 0, 0, target.width, target.height);
}

async function requestFrame() {
  const now = performance.now();
  const moving = now - lastChange < REST_MS;
  const wanted = version;
  const c = currentCamera();
  let url;
  let full = true;
  if (view.snapped) {
    url = `/api/compare?split=${view.snapped.split}&index=${view.snapped.index}&mode=${view.error ? 'error' : 'colour'}`;
  } else {
    const pixels = c.width * c.height;
    const coarse = Math.min(1, Math.sqrt(COARSE_SECONDS / (secondsPerPixel * pixels)));
    full = !moving || coarse >= 1;
    const s = full ? 1 : Math.max(coarse, 1 / 16);
    const w = Math.max(8, Math.round(c.width * s));
    const h = Math.max(8, Math.round(c.height * s));
    url = renderUrl(c, w, h, full, view.depth ? 'depth' : 'colour');
  }
  inFlight = true;
  try {
    const started = performance.now();
    const { bitmap, headers } = await fetchImage(url);
    const seconds = parseFloat(headers.get('X-Render-Seconds') || '0');
    const pixels = bitmap.width * bitmap.height;
    const withLens = full && lens.aperture > 0 && !view.snapped;
    if (seconds > 0 && !withLens) secondsPerPixel = 0.5 * secondsPerPixel + 0.5 * seconds / pixels;
    if (canvas.width !== c.width || canvas.height !== c.height) resizeCanvases(c.width, c.height);
    draw(canvas, bitmap);
    lastRender = { seconds, round: (performance.now() - started) / 1000, width: bitmap.width, height: bitmap.height,
                   samples: parseInt(headers.get('X-Samples') || '0', 10), full };
    frameTimes.push(performance.now());
    frameLog.push({ t: performance.now(), full, width: bitmap.width, height: bitmap.height, seconds,
                    round: lastRender.round });
    if (frameLog.length > 1000) frameLog.shift();
    if (view.snapped) showScore(headers);
    shown = { version: wanted, full };
    $('message').textContent = '';
  } catch (e) {
    $('message').textContent = String(e.message || e);
    shown = { version: wanted, full: true };
  } finally {
    inFlight = false;
  }
}

function tick() {
  requestAnimationFrame(tick);
  while (frameTimes.length && performance.now() - frameTimes[0] > 1000) frameTimes.shift();
  showStats();
  if (!info || inFlight) return;
  if (shown.version === version && shown.full) return;
  const resting = performance.now() - lastChange >= REST_MS;
  // A coarse frame of this very camera is on screen: wait for rest before refining it.
  if (shown.version === version && !resting) return;
  requestFrame();
}

// ---- the dataset --------------------------------------------------------------------------
async function snap(camera) {
  view.snapped = camera;
  $('cameras').value = `${camera.split}:${camera.index}`;
  $('truthView').classList.add('shown');
  $('truthCaption').textContent = `${camera.name} (${camera.split})`;
  $('renderCaption').textContent = view.error ? 'error ×4' : 'render';
  resizeCanvases(camera.width, camera.height);
  changed(false);
  try {
    const { bitmap } = await fetchImage(`/api/truth?split=${camera.split}&index=${camera.index}`);
    truthCanvas.width = bitmap.width;
    truthCanvas.height = bitmap.height;
    draw(truthCanvas, bitmap);
  } catch (e) {
    $('message').textContent = String(e.message || e);
  }
}

function unsnap(keepPose) {
  if (!view.snapped) return;
  if (keepPose) orbitFrom(fromRowMajor(view.snapped.c2w));
  view.snapped = null;
  view.error = false;
  $('error').checked = false;
  $('truthView').classList.remove('shown');
  $('renderCaption').textContent = 'render';
  $('score').textContent = '';
  resizeCanvases(view.width, view.height);
  changed(false);
}

// The dataset camera closest to the current one, in position and in viewing direction.
function nearestCamera() {
  const c = currentCamera().b;
  let best = null;
  let bestCost = Infinity;
  for (const d of info.cameras) {
    const b = fromRowMajor(d.c2w);
    const cost = Math.hypot(...sub(b.eye, c.eye)) / info.radius + (1 - dot(b.back, c.back));
    if (cost < bestCost) { bestCost = cost; best = d; }
  }
  return best;
}

function showScore(headers) {
  const psnr = headers.get('X-PSNR');
  const ssim = headers.get('X-SSIM');
  $('score').textContent = `PSNR ${psnr} dB · SSIM ${ssim} (render against the image, on the model's background)`;
}

// ---- drawing ------------------------------------------------------------------------------
function resizeCanvases(width, height) {
  canvas.width = width;
  canvas.height = height;
  fitCanvases();
}

// Fits the render (and the truth beside it) into the stage, keeping the aspect ratio.
function fitCanvases() {
  const area = $('renderView').getBoundingClientRect();
  const s = Math.min(area.width / canvas.width, area.height / canvas.height);
  for (const c of [canvas, overlay, truthCanvas]) {
    c.style.width = `${Math.floor(canvas.width * s)}px`;
    c.style.height = `${Math.floor(canvas.height * s)}px`;
  }
  // The cameras are drawn at the screen's resolution, whatever the render's.
  overlay.width = Math.floor(canvas.width * s * devicePixelRatio);
  overlay.height = Math.floor(canvas.height * s * devicePixelRatio);
  drawOverlay();
}

function drawOverlay() {
  const g = overlay.getContext('2d');
  g.clearRect(0, 0, overlay.width, overlay.height);
  if (!info || !view.frustums || !info.cameras.length) return;
  const c = currentCamera();
  const f = 0.5 * overlay.height / Math.tan(0.5 * c.fov * Math.PI / 180);
  const project = (p) => {
    const d = sub(p, c.b.eye);
    const x = dot(d, c.b.right);
    const y = dot(d, c.b.up);
    const z = -dot(d, c.b.back);
    if (z < 1e-3 * info.radius) return null;
    return [0.5 * overlay.width + f * x / z, 0.5 * overlay.height - f * y / z];
  };
  const size = 0.08 * info.radius;
  const colours = { train: 'rgba(200,200,200,0.55)', val: 'rgba(255,210,80,0.8)', test: 'rgba(95,179,255,0.85)' };
  g.lineWidth = devicePixelRatio;
  for (const d of info.cameras) {
    if (view.snapped && d.split === view.snapped.split && d.index === view.snapped.index) continue;
    const b = fromRowMajor(d.c2w);
    const t = Math.tan(0.5 * d.fov_y_degrees * Math.PI / 180);
    const aspect = d.width / d.height;
    const corner = (sx, sy) => add(b.eye, add(scale(b.back, -size), add(scale(b.right, sx * t * aspect * size), scale(b.up, sy * t * size))));
    const points = [b.eye, corner(-1, 1), corner(1, 1), corner(1, -1), corner(-1, -1)].map(project);
    if (points.some((p) => p === null)) continue;
    g.strokeStyle = colours[d.split] || colours.train;
    g.beginPath();
    for (let i = 1; i <= 4; i++) { g.moveTo(...points[0]); g.lineTo(...points[i]); }
    g.moveTo(...points[1]);
    for (let i = 2; i <= 4; i++) g.lineTo(...points[i]);
    g.closePath();
    g.stroke();
  }
}

function showStats() {
  if (!info) return;
  const fps = frameTimes.length;
  const r = lastRender;
  const kind = r.full ? 'full' : 'coarse';
  $('stats').textContent =
    `${fps} frames/s · last ${kind} frame ${r.width}×${r.height}\n` +
    `render ${(1000 * r.seconds).toFixed(0)} ms · round trip ${(1000 * (r.round || 0)).toFixed(0)} ms` +
    (r.samples ? ` · ${r.samples.toLocaleString()} samples` : '');
}

// ---- input --------------------------------------------------------------------------------
function setupInput() {
  let drag = null;
  canvas.addEventListener('contextmenu', (e) => e.preventDefault());
  canvas.addEventListener('pointerdown', (e) => {
    canvas.setPointerCapture(e.pointerId);
    canvas.focus();
    drag = { x: e.clientX, y: e.clientY, x0: e.clientX, y0: e.clientY, pan: e.button === 2 || e.shiftKey };
    canvas.classList.add('dragging');
  });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x;
    const dy = e.clientY - drag.y;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (Math.hypot(e.clientX - drag.x0, e.clientY - drag.y0) < 3 && !drag.moved) return;
    drag.moved = true;
    if (drag.pan) {
      const b = basis();
      const k = 2 * Math.tan(0.5 * cam.fov * Math.PI / 180) * cam.dist / canvas.getBoundingClientRect().height;
      moveCamera(() => { cam.target = add(cam.target, add(scale(b.right, -dx * k), scale(b.up, dy * k))); });
    } else {
      moveCamera(() => { cam.yaw -= dx * 0.008; cam.pitch += dy * 0.008; });
    }
  });
  canvas.addEventListener('pointerup', (e) => {
    const clicked = drag && !drag.moved;
    drag = null;
    canvas.classList.remove('dragging');
    if (clicked) focusAt(e);
  });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    moveCamera(() => { cam.dist *= Math.exp(0.0015 * e.deltaY); });
  }, { passive: false });
  window.addEventListener('keydown', (e) => {
    if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
    const b = basis();
    const step = 0.05 * cam.dist;
    const moves = {
      KeyW: () => { cam.target = add(cam.target, scale(b.back, -step)); },
      KeyS: () => { cam.target = add(cam.target, scale(b.back, step)); },
      KeyA: () => { cam.target = add(cam.target, scale(b.right, -step)); },
      KeyD: () => { cam.target = add(cam.target, scale(b.right, step)); },
      KeyQ: () => { cam.target = add(cam.target, [0, 0, -step]); },
      KeyE: () => { cam.target = add(cam.target, [0, 0, step]); },
      ArrowLeft: () => { cam.yaw += 0.05; },
      ArrowRight: () => { cam.yaw -= 0.05; },
      ArrowUp: () => { cam.pitch += 0.05; },
      ArrowDown: () => { cam.pitch -= 0.05; },
    };
    if (e.code === 'KeyR') { reset(); return; }
    if (moves[e.code]) { e.preventDefault(); moveCamera(moves[e.code]); }
  });
  window.addEventListener('resize', fitCanvases);
}

// Focuses the lens on the surface under the pointer: the server marches that one ray.
async function focusAt(e) {
  const rect = canvas.getBoundingClientRect();
  const c = currentCamera();
  const x = Math.min(c.width - 1, Math.floor((e.clientX - rect.left) / rect.width * c.width));
  const y = Math.min(c.height - 1, Math.floor((e.clientY - rect.top) / rect.height * c.height));
  const q = new URLSearchParams({
    c2w: rowMajor(c.b).map((v) => v.toPrecision(9)).join(','), fov: c.fov.toPrecision(9), w: c.width, h: c.height, x, y,
  });
  try {
    const response = await fetch('/api/depth?' + q);
    if (!response.ok) throw new Error(`${response.status}: ${await response.text()}`);
    const hit = await response.json();
    if (!hit.hit) { $('message').textContent = 'nothing there to focus on'; return; }
    setFocus(hit.focus);
    $('message').textContent = `focused at ${hit.focus.toFixed(3)} (pixel ${x}, ${y})`;
  } catch (err) {
    $('message').textContent = String(err.message || err);
  }
}

function setFocus(value) {
  lens.focus = value;
  const f = $('focus');
  f.max = Math.max(parseFloat(f.max), value);
  f.value = value;
  $('focusOut').textContent = value.toFixed(2);
  if (lens.aperture > 0) changed(false);
}

function setupControls() {
  const resolution = $('resolution');
  const sizes = [[info.width, info.height]];
  for (const long of [400, 800]) {
    const s = long / Math.max(info.width, info.height);
    if (s > 1) sizes.push([Math.round(info.width * s), Math.round(info.height * s)]);
  }
  for (const [w, h] of sizes) resolution.add(new Option(`${w} × ${h}`, `${w}x${h}`));
  resolution.addEventListener('change', () => {
    [view.width, view.height] = resolution.value.split('x').map(Number);
    if (!view.snapped) resizeCanvases(view.width, view.height);
    changed(false);
  });

  const fov = $('fov');
  fov.value = cam.fov;
  $('fovOut').textContent = `${cam.fov.toFixed(1)}°`;
  fov.addEventListener('input', () => {
    $('fovOut').textContent = `${parseFloat(fov.value).toFixed(1)}°`;
    moveCamera(() => { cam.fov = parseFloat(fov.value); });
  });

  const aperture = $('aperture');
  aperture.max = 0.1 * info.radius;
  aperture.step = 0.0005 * info.radius;
  aperture.value = 0;
  $('apertureOut').textContent = '0';
  aperture.addEventListener('input', () => {
    lens.aperture = parseFloat(aperture.value);
    $('apertureOut').textContent = lens.aperture.toFixed(3);
    changed(false);
  });
  const focus = $('focus');
  focus.min = 0.05 * info.radius;
  focus.max = 3 * info.radius;
  focus.step = 0.001 * info.radius;
  setFocus(info.radius);
  focus.addEventListener('input', () => setFocus(parseFloat(focus.value)));
  $('lensRays').addEventListener('change', (e) => {
    lens.rays = Math.max(1, Math.min(256, parseInt(e.target.value, 10) || 16));
    e.target.value = lens.rays;
    if (lens.aperture > 0) changed(false);
  });

  $('depth').addEventListener('change', (e) => { view.depth = e.target.checked; changed(false); });
  $('frustums').addEventListener('change', (e) => { view.frustums = e.target.checked; drawOverlay(); });
  $('reset').addEventListener('click', reset);

  const list = $('cameras');
  if (!info.cameras.length) {
    list.add(new Option('no dataset (lucid view CKPT --dataset DIR)', ''));
    for (const id of ['snap', 'nearest', 'error', 'cameras']) $(id).disabled = true;
  }
  for (const d of info.cameras) list.add(new Option(`${d.split} ${d.index}: ${d.name}`, `${d.split}:${d.index}`));
  const byKey = (key) => info.cameras.find((d) => `${d.split}:${d.index}` === key);
  $('snap').addEventListener('click', () => { const d = byKey(list.value); if (d) snap(d); });
  list.addEventListener('change', () => { if (view.snapped) { const d = byKey(list.value); if (d) snap(d); } });
  $('nearest').addEventListener('click', () => { const d = nearestCamera(); if (d) snap(d); });
  $('unsnap').addEventListener('click', () => unsnap(true));
  $('error').addEventListener('change', (e) => {
    view.error = e.target.checked;
    if (view.error && !view.snapped) { const d = nearestCamera(); if (d) snap(d); return; }
    $('renderCaption').textContent = view.error ? 'error ×4' : 'render';
    changed(false);
  });
}

async function main() {
  try {
    const response = await fetch('/api/info');
    info = await response.json();
  } catch (e) {
    $('message').textContent = `cannot reach the viewer: ${e}`;
    return;
  }
  $('model').textContent = `${info.kind === 'nerf' ? 'NeRF' : '3D Gaussian splats'}, step ${info.step}` +
    (info.dataset ? ` · dataset ${info.dataset} (${info.cameras.length} cameras)` : '');
  document.title = `Lucid viewer — ${info.checkpoint}`;
  view.width = info.width;
  view.height = info.height;
  cam.fov = info.fov_y_degrees;
  setupControls();
  setupInput();
  resizeCanvases(view.width, view.height);
  reset();
  requestAnimationFrame(tick);
}

main();
