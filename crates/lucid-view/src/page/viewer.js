// Lucid's viewer page: an orbit camera in the model's frame (+Z up), renders requested from
// the server one at a time (coarse while the camera moves, full resolution once it rests),
// the dataset's cameras drawn over the render, and comparisons with the dataset's images.
'use strict';

const $ = (id) => document.getElementById(id);
const canvas = $('render');
const overlay = $('overlay');
const truthCanvas = $('truth');

// How long the camera must rest before the full-resolution frame is asked for, and how long
// a frame may take to render while it moves: 15 frames/s, with two requests in flight (the
// coarse frame's size adapts to the renderer's measured speed). The render is ~90 % of the
// server's time per frame (the rest: quantising, sending; splats at 400×400 rendered in 54–61
// ms at 17–14.6 frames/s), so it gets 90 % of a frame's interval.
const REST_MS = 150;
const COARSE_SECONDS = 0.9 / 15;

let info = null;
const cam = { target: [0, 0, 0], yaw: 0, pitch: 0.5, dist: 4, fov: 40 };
const lens = { aperture: 0, focus: 4, rays: 16 };
const view = { depth: false, frustums: true, error: false, snapped: null, fixed: null, width: 200, height: 200 };
const keyframes = [];

let version = 0;          // bumped by every change of what should be on screen
let lastChange = 0;       // when the camera last moved
let shown = { version: -1, full: false };
let requested = { version: -1, full: false };
let inFlight = 0;
let sequence = 0;         // requests in the order sent; an older reply never replaces a newer one
let shownSequence = 0;
let retryAt = 0;          // after a 503, when to ask again
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

// The camera on screen: a snapped dataset camera exactly, a fixed pose (a keyframe, a frame of
// the path's preview), else the orbit camera.
function currentCamera() {
  if (view.snapped) {
    const c = view.snapped;
    return { b: fromRowMajor(c.c2w), fov: c.fov_y_degrees, width: c.width, height: c.height };
  }
  if (view.fixed) return { b: fromRowMajor(view.fixed.c2w), fov: view.fixed.fov, width: view.width, height: view.height };
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
  if (view.fixed) { orbitFrom(fromRowMajor(view.fixed.c2w)); cam.fov = view.fixed.fov; view.fixed = null; stopPreview(); }
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
  view.fixed = null;
  stopPreview();
  unsnap(false);
  changed(true);
}

// ---- requests -----------------------------------------------------------------------------
function renderUrl(c, width, height, withLens, mode) {
  const q = new URLSearchParams({
    c2w: rowMajor(c.b).map((v) => v.toPrecision(9)).join(','),
    fov: c.fov.toPrecision(9), w: width, h: height, mode, format: 'rgb',
  });
  if (withLens && lens.aperture > 0) {
    q.set('aperture', lens.aperture);
    q.set('focus', lens.focus);
    q.set('lens_rays', lens.rays);
  }
  return '/api/render?' + q;
}

// Renders come as raw RGB bytes (format=rgb): over the loopback a PNG's encoding and
// decoding cost more CPU, which the renderer shares, than sending the bytes.
async function fetchImage(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${response.status}: ${await response.text()}`);
  const width = parseInt(response.headers.get('X-Width') || '0', 10);
  const height = parseInt(response.headers.get('X-Height') || '0', 10);
  if (!width || !height) return { bitmap: await createImageBitmap(await response.blob()), headers: response.headers };
  const rgb = new Uint8Array(await response.arrayBuffer());
  if (rgb.length !== 3 * width * height) throw new Error(`a ${width}x${height} frame of ${rgb.length} bytes`);
  const rgba = new Uint8ClampedArray(4 * width * height);
  for (let i = 0, j = 0; i < rgb.length; i += 3, j += 4) {
    rgba[j] = rgb[i];
    rgba[j + 1] = rgb[i + 1];
    rgba[j + 2] = rgb[i + 2];
    rgba[j + 3] = 255;
  }
  return { bitmap: await createImageBitmap(new ImageData(rgba, width, height)), headers: response.headers };
}

function draw(target, bitmap) {
  const g = target.getContext('2d');
  g.imageSmoothingEnabled = true;
  // A coarse frame is stretched while the camera moves: bilinear is enough then, and cheaper.
  g.imageSmoothingQuality = bitmap.width === target.width ? 'high' : 'low';
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
  inFlight++;
  const mine = ++sequence;
  requested = { version: wanted, full };
  try {
    const started = performance.now();
    const { bitmap, headers } = await fetchImage(url);
    if (mine < shownSequence) return;
    shownSequence = mine;
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
    // A busy renderer (a training step goes first) is asked again; anything else is shown.
    if (String(e.message).startsWith('503')) { requested = { version: -1, full: false }; retryAt = performance.now() + 250; return; }
    $('message').textContent = String(e.message || e);
    shown = { version: wanted, full: true };
  } finally {
    inFlight--;
  }
}

// Polls often while frames are wanted, rarely at rest: an idle page costs the CPU (which the
// renderer, or a training run, shares) almost nothing.
function tick() {
  const busy = inFlight > 0 || shown.version !== version || !shown.full || performance.now() - lastChange < 1000;
  setTimeout(tick, busy ? 15 : 100);
  while (frameTimes.length && performance.now() - frameTimes[0] > 1000) frameTimes.shift();
  showStats();
  if (!info || performance.now() < retryAt) return;
  const resting = performance.now() - lastChange >= REST_MS;
  // On screen or on its way already: a full frame of this camera, or while it moves a coarse one.
  const covers = (frame) => frame.version === version && (frame.full || !resting);
  if (covers(shown) || covers(requested)) return;
  // While the camera moves two requests are in flight, so the server renders the next frame
  // while the browser receives and draws the last; at rest, one.
  if (inFlight >= (resting || info.live ? 1 : 2)) return;
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
  const text =
    `${fps} frames/s · last ${kind} frame ${r.width}×${r.height}\n` +
    `render ${(1000 * r.seconds).toFixed(0)} ms · round trip ${(1000 * (r.round || 0)).toFixed(0)} ms` +
    (r.samples ? ` · ${r.samples.toLocaleString()} samples` : '');
  // Only a change is written: a page at rest lays nothing out again (the CPU is the renderer's).
  const stats = $('stats');
  if (stats.textContent !== text) stats.textContent = text;
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

// ---- camera paths -------------------------------------------------------------------------
// Rotation matrix (row-major 3×3 inside a row-major 4×4) to a unit quaternion [x, y, z, w].
function quaternion(m) {
  const [a, b, c, d, e, f, g, h, i] = [m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]];
  const t = a + e + i;
  let q;
  if (t > 0) { const s = 2 * Math.sqrt(t + 1); q = [(h - f) / s, (c - g) / s, (d - b) / s, s / 4]; }
  else if (a > e && a > i) { const s = 2 * Math.sqrt(1 + a - e - i); q = [s / 4, (b + d) / s, (c + g) / s, (h - f) / s]; }
  else if (e > i) { const s = 2 * Math.sqrt(1 + e - a - i); q = [(b + d) / s, s / 4, (f + h) / s, (c - g) / s]; }
  else { const s = 2 * Math.sqrt(1 + i - a - e); q = [(c + g) / s, (f + h) / s, s / 4, (d - b) / s]; }
  const n = Math.hypot(...q);
  return q.map((v) => v / n);
}

function rotation([x, y, z, w]) {
  return [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
          2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
          2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)];
}

function slerp(a, b, t) {
  let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  if (d < 0) { b = b.map((v) => -v); d = -d; }
  if (d > 0.9995) { const q = a.map((v, k) => v + t * (b[k] - v)); const n = Math.hypot(...q); return q.map((v) => v / n); }
  const theta = Math.acos(d);
  const s = Math.sin(theta);
  return a.map((v, k) => (Math.sin((1 - t) * theta) * v + Math.sin(t * theta) * b[k]) / s);
}

// Catmull-Rom through the keyframes' positions, the rotations slerped, field of view and lens
// linear, segments of equal time.
function pathFrames(count) {
  const n = keyframes.length;
  const at = (k) => keyframes[Math.max(0, Math.min(n - 1, k))];
  const position = (k) => [at(k).c2w[3], at(k).c2w[7], at(k).c2w[11]];
  const frames = [];
  for (let j = 0; j < count; j++) {
    const u = n === 1 || count === 1 ? 0 : (j / (count - 1)) * (n - 1);
    const k = Math.min(Math.floor(u), n - 2 < 0 ? 0 : n - 2);
    const t = n === 1 ? 0 : u - k;
    const [p0, p1, p2, p3] = [position(k - 1), position(k), position(k + 1), position(k + 2)];
    const p = [0, 1, 2].map((c) => 0.5 * (2 * p1[c] + (-p0[c] + p2[c]) * t + (2 * p0[c] - 5 * p1[c] + 4 * p2[c] - p3[c]) * t * t
      + (-p0[c] + 3 * p1[c] - 3 * p2[c] + p3[c]) * t * t * t));
    const r = rotation(slerp(quaternion(at(k).c2w), quaternion(at(k + 1).c2w), t));
    const mix = (key) => at(k)[key] + t * (at(k + 1)[key] - at(k)[key]);
    frames.push({ c2w: [r[0], r[1], r[2], p[0], r[3], r[4], r[5], p[1], r[6], r[7], r[8], p[2], 0, 0, 0, 1],
                  fov: mix('fov'), aperture: mix('aperture'), focus: mix('focus') });
  }
  return frames;
}

// A pose (row-major) and lengths from the model's frame into the dataset's.
function toDataset(frame) {
  const d = info.to_dataset;
  if (!d) return frame;
  const R = d.rotation;
  const m = frame.c2w;
  const mul = (row, col) => R[3 * row] * m[col] + R[3 * row + 1] * m[4 + col] + R[3 * row + 2] * m[8 + col];
  const c2w = [];
  for (let row = 0; row < 3; row++) {
    c2w.push(mul(row, 0), mul(row, 1), mul(row, 2), mul(row, 3) / d.scale + d.centre[row]);
  }
  c2w.push(0, 0, 0, 1);
  return { ...frame, c2w, aperture: frame.aperture / d.scale, focus: frame.focus / d.scale };
}

function cameraPathJson() {
  const seconds = Math.max(0.1, parseFloat($('seconds').value) || 4);
  const fps = Math.max(1, parseFloat($('pathFps').value) || 30);
  const count = keyframes.length === 1 ? 1 : Math.max(2, Math.round(seconds * fps));
  const aspect = view.width / view.height;
  const entry = (f) => {
    const g = toDataset(f);
    const e = { camera_to_world: g.c2w, fov: g.fov, aspect };
    if (g.aperture > 0) { e.aperture_radius = g.aperture; e.focus_distance = g.focus; }
    return e;
  };
  return {
    camera_type: 'perspective', render_width: view.width, render_height: view.height, fps, seconds,
    smoothness_value: 0.5, is_cycle: false, crop: null,
    keyframes: keyframes.map((k) => { const g = toDataset(k); return { matrix: g.c2w, fov: g.fov, aspect,
      override_transition_enabled: false, override_transition_sec: null }; }),
    camera_path: pathFrames(count).map(entry),
  };
}

function showKeyframes() {
  const list = $('keys');
  list.textContent = '';
  keyframes.forEach((k, i) => {
    const row = document.createElement('div');
    const label = document.createElement('span');
    label.textContent = `${i + 1}. fov ${k.fov.toFixed(1)}°` + (k.aperture > 0 ? ` · lens ${k.aperture.toFixed(3)} @ ${k.focus.toFixed(2)}` : '');
    label.title = 'go to this keyframe';
    label.addEventListener('click', () => { stopPreview(); goTo(k); });
    const remove = document.createElement('button');
    remove.textContent = '×';
    remove.title = 'remove';
    remove.addEventListener('click', () => { keyframes.splice(i, 1); showKeyframes(); });
    row.append(label, remove);
    list.append(row);
  });
}

function goTo(frame) {
  if (view.snapped) unsnap(false);
  view.fixed = { c2w: frame.c2w, fov: frame.fov };
  lens.aperture = frame.aperture;
  $('aperture').value = frame.aperture;
  $('apertureOut').textContent = frame.aperture.toFixed(3);
  setFocus(frame.focus);
  changed(true);
}

let previewTimer = null;
function stopPreview() {
  if (previewTimer) clearInterval(previewTimer);
  previewTimer = null;
  $('preview').textContent = 'Preview';
}

function preview() {
  if (previewTimer) { stopPreview(); return; }
  if (keyframes.length < 2) { $('message').textContent = 'a path needs two keyframes'; return; }
  const fps = Math.max(1, parseFloat($('pathFps').value) || 30);
  const frames = pathFrames(Math.max(2, Math.round((parseFloat($('seconds').value) || 4) * fps)));
  let j = 0;
  $('preview').textContent = 'Stop';
  previewTimer = setInterval(() => {
    if (j >= frames.length) { stopPreview(); return; }
    goTo(frames[j++]);
  }, 1000 / fps);
}

function setupPath() {
  $('addKey').addEventListener('click', () => {
    const c = currentCamera();
    keyframes.push({ c2w: rowMajor(c.b), fov: c.fov, aperture: lens.aperture, focus: lens.focus });
    showKeyframes();
  });
  $('clearKeys').addEventListener('click', () => { keyframes.length = 0; stopPreview(); showKeyframes(); });
  $('preview').addEventListener('click', preview);
  $('savePath').addEventListener('click', () => {
    if (!keyframes.length) { $('message').textContent = 'add a keyframe first'; return; }
    const blob = new Blob([JSON.stringify(cameraPathJson(), null, 1)], { type: 'application/json' });
    const a = document.createElement('a');
    a.href = URL.createObjectURL(blob);
    a.download = 'camera_path.json';
    a.click();
    URL.revokeObjectURL(a.href);
  });
}

// ---- a run in training ---------------------------------------------------------------------
let trainedStep = -1;
let lastRefresh = 0;

async function pollStatus() {
  let status;
  try {
    const response = await fetch('/api/status');
    status = await response.json();
  } catch (e) {
    $('trainingStats').textContent = 'training has ended (the server is gone); view the checkpoint with lucid view';
    return;
  }
  const last = status.held_out && status.held_out.length ? status.held_out[status.held_out.length - 1] : null;
  $('trainingStats').textContent = `step ${status.step} · ${(status.seconds || 0).toFixed(0)} s · loss ${(status.loss || 0).toFixed(5)}` +
    (status.psnr ? ` · batch ${status.psnr.toFixed(2)} dB` : '') +
    (last ? `\nheld-out (${status.held_out_split}) ${last.psnr.toFixed(2)} dB at step ${last.step}` : '') +
    `\nviewer's share of the time ${(100 * (status.view_share || 0)).toFixed(1)} %`;
  drawCurve(status);
  // At rest, the frame follows the training every few seconds.
  const now = performance.now();
  if (status.step !== trainedStep && now - lastRefresh > 3000 && now - lastChange > REST_MS && !view.snapped) {
    trainedStep = status.step;
    lastRefresh = now;
    changed(false);
  }
  setTimeout(pollStatus, 1000);
}

function drawCurve(status) {
  const c = $('curve');
  const g = c.getContext('2d');
  g.clearRect(0, 0, c.width, c.height);
  const line = (status.losses || []).filter((p) => p.psnr > 0);
  const dots = status.held_out || [];
  const all = line.map((p) => p.psnr).concat(dots.map((p) => p.psnr));
  if (!all.length) return;
  const t1 = Math.max(1, ...line.map((p) => p.seconds), ...dots.map((p) => p.seconds));
  const lo = Math.floor(Math.min(...all));
  const hi = Math.ceil(Math.max(...all));
  const x = (t) => 40 + (c.width - 50) * t / t1;
  const y = (v) => c.height - 20 - (c.height - 30) * (v - lo) / Math.max(1, hi - lo);
  g.fillStyle = '#8b8f99';
  g.font = '20px system-ui';
  g.fillText(`${hi} dB`, 2, 20);
  g.fillText(`${lo}`, 2, c.height - 20);
  g.fillText(`${t1.toFixed(0)} s`, c.width - 60, c.height - 2);
  g.strokeStyle = '#8b8f99';
  g.lineWidth = 2;
  g.beginPath();
  line.forEach((p, i) => (i ? g.lineTo(x(p.seconds), y(p.psnr)) : g.moveTo(x(p.seconds), y(p.psnr))));
  g.stroke();
  g.fillStyle = '#5fb3ff';
  for (const p of dots) { g.beginPath(); g.arc(x(p.seconds), y(p.psnr), 5, 0, 2 * Math.PI); g.fill(); }
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
  setupPath();
  resizeCanvases(view.width, view.height);
  reset();
  tick();
  if (info.live) {
    $('training').hidden = false;
    pollStatus();
  }
}

main();
