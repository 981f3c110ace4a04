// A 3D Gaussian splat viewer in WebGL2, exported by `lucid export web`: the splats of
// splats.bin drawn as depth-sorted, alpha-blended EWA ellipses (the projection of Lucid's
// rasterizer: covariance J W Σ Wᵀ Jᵀ plus a 0.3 px² low-pass, opacity clamped at 0.99, colour
// from spherical harmonics to degree 1, max(·, 0)), back to front over the background.
// Everything it needs is in this folder; any static file server serves it.
'use strict';

const canvas = document.getElementById('view');
const gl = canvas.getContext('webgl2', { antialias: false, premultipliedAlpha: false, preserveDrawingBuffer: true });
const status = document.getElementById('status');

const VERTEX = `#version 300 es
precision highp float;
precision highp int;
uniform highp sampler2D u_data;
uniform mat3 u_rotation;    // world to camera (x right, y down, z forward)
uniform vec3 u_eye;
uniform vec4 u_intrinsics;  // fx, fy, cx, cy in pixels
uniform vec2 u_size;        // width, height in pixels
uniform vec2 u_limits;      // the Jacobian's |x/z| and |y/z| clamps
in vec2 a_corner;
in uint a_index;
out vec4 v_colour;
out vec3 v_conic;
out vec2 v_offset;

vec4 texel(int k) {
  return texelFetch(u_data, ivec2(k % 4096, k / 4096), 0);
}

void main() {
  int base = int(a_index) * 6;
  vec4 t0 = texel(base);      // mean, opacity
  vec4 t1 = texel(base + 1);  // Σ xx xy xz yy
  vec4 t2 = texel(base + 2);  // Σ yz zz, SH dc r g
  vec4 t3 = texel(base + 3);  // SH dc b, k=1 rgb
  vec4 t4 = texel(base + 4);  // SH k=2 rgb, k=3 r
  vec4 t5 = texel(base + 5);  // SH k=3 g b
  vec3 view = u_rotation * (t0.xyz - u_eye);
  if (view.z < 0.01) { gl_Position = vec4(0.0, 0.0, 2.0, 1.0); return; }
  mat3 sigma = mat3(t1.x, t1.y, t1.z, t1.y, t1.w, t2.x, t1.z, t2.x, t2.y);
  float z = view.z;
  vec2 ratio = clamp(view.xy / z, -u_limits, u_limits);
  // Rows of the projection's Jacobian, turned into world space.
  vec3 j0 = vec3(u_intrinsics.x / z, 0.0, -u_intrinsics.x * ratio.x / z) * u_rotation;
  vec3 j1 = vec3(0.0, u_intrinsics.y / z, -u_intrinsics.y * ratio.y / z) * u_rotation;
  vec3 s0 = sigma * j0;
  vec3 s1 = sigma * j1;
  vec3 cov = vec3(dot(j0, s0) + 0.3, dot(j0, s1), dot(j1, s1) + 0.3);
  float det = cov.x * cov.z - cov.y * cov.y;
  if (det <= 0.0) { gl_Position = vec4(0.0, 0.0, 2.0, 1.0); return; }
  v_conic = vec3(cov.z, -cov.y, cov.x) / det;
  vec2 centre = u_intrinsics.zw + u_intrinsics.xy * view.xy / z;
  // The axis-aligned box of the 3σ ellipse.
  vec2 half_extent = 3.0 * sqrt(vec2(cov.x, cov.z));
  v_offset = a_corner * half_extent;
  vec2 pixel = centre + v_offset;
  gl_Position = vec4(2.0 * pixel.x / u_size.x - 1.0, 1.0 - 2.0 * pixel.y / u_size.y, 0.0, 1.0);

  vec3 d = normalize(t0.xyz - u_eye);
  const float C0 = 0.28209479177387814;
  const float C1 = 0.4886025119029199;
  vec3 dc = vec3(t2.z, t2.w, t3.x);
  vec3 k1 = t3.yzw;
  vec3 k2 = t4.xyz;
  vec3 k3 = vec3(t4.w, t5.x, t5.y);
  vec3 colour = C0 * dc - C1 * d.y * k1 + C1 * d.z * k2 - C1 * d.x * k3 + 0.5;
  v_colour = vec4(max(colour, 0.0), t0.w);
}`;

const FRAGMENT = `#version 300 es
precision highp float;
in vec4 v_colour;
in vec3 v_conic;
in vec2 v_offset;
out vec4 fragment;
void main() {
  vec2 d = v_offset;
  float power = -0.5 * (v_conic.x * d.x * d.x + v_conic.z * d.y * d.y) - v_conic.y * d.x * d.y;
  // Lucid's rasterizer stops at the 3σ ellipse.
  if (power > 0.0 || power < -4.5) discard;
  float alpha = min(0.99, v_colour.a * exp(power));
  if (alpha < 1.0 / 255.0) discard;
  fragment = vec4(v_colour.rgb * alpha, alpha);
}`;

function compile(type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(shader));
  return shader;
}

// IEEE half floats to numbers.
function halfToFloat(h) {
  const s = h & 0x8000 ? -1 : 1;
  const e = (h >> 10) & 0x1f;
  const f = h & 0x3ff;
  if (e === 0) return s * f * 2 ** -24;
  if (e === 31) return f ? NaN : s * Infinity;
  return s * (1 + f / 1024) * 2 ** (e - 15);
}

// splats.bin: per splat 52 bytes, little-endian: mean f32×3, scale f16×3 (standard deviations),
// rotation f16×4 (w, x, y, z), opacity f16, SH f16×12 (DC rgb, then degree-1 coefficients
// k = 1..3, rgb each).
function decode(buffer, count) {
  const view = new DataView(buffer);
  const texels = 6;
  const width = 4096;
  const rows = Math.ceil((count * texels) / width);
  const data = new Float32Array(width * rows * 4);
  const means = new Float32Array(count * 3);
  for (let i = 0; i < count; i++) {
    const o = i * 52;
    const h = (k) => halfToFloat(view.getUint16(o + 12 + 2 * k, true));
    const m = [view.getFloat32(o, true), view.getFloat32(o + 4, true), view.getFloat32(o + 8, true)];
    const [sx, sy, sz] = [h(0), h(1), h(2)];
    let [w, x, y, z] = [h(3), h(4), h(5), h(6)];
    const n = Math.hypot(w, x, y, z) || 1;
    [w, x, y, z] = [w / n, x / n, y / n, z / n];
    // Σ = R S² Rᵀ.
    const r = [
      1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
      2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
      2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
    ];
    const s2 = [sx * sx, sy * sy, sz * sz];
    const cov = (a, b) => r[3 * a] * r[3 * b] * s2[0] + r[3 * a + 1] * r[3 * b + 1] * s2[1] + r[3 * a + 2] * r[3 * b + 2] * s2[2];
    const sh = Array.from({ length: 12 }, (_, k) => h(8 + k));
    const values = [m[0], m[1], m[2], h(7), cov(0, 0), cov(0, 1), cov(0, 2), cov(1, 1),
                    cov(1, 2), cov(2, 2), sh[0], sh[1], sh[2], sh[3], sh[4], sh[5],
                    sh[6], sh[7], sh[8], sh[9], sh[10], sh[11], 0, 0];
    data.set(values, i * texels * 4);
    means.set(m, i * 3);
  }
  return { data, width, rows, means };
}

const scene = { count: 0, means: null };
const camera = { target: [0, 0, 0], yaw: 0.8, pitch: 0.45, dist: 4, fov: 40, fixed: null };
let program = null;
let indexBuffer = null;
let indices = null;
let dirty = true;
let drawMs = 0;           // the last frame's sort and draw, for a readout

function basis() {
  if (camera.fixed) return camera.fixed;
  const c = Math.cos(camera.pitch);
  const eye = [0, 1, 2].map((k) => camera.target[k] + camera.dist * [c * Math.cos(camera.yaw), c * Math.sin(camera.yaw), Math.sin(camera.pitch)][k]);
  const back = normalise(eye.map((v, k) => v - camera.target[k]));
  const right = normalise(cross([0, 0, 1], back));
  const up = cross(back, right);
  return { right, up, back, eye };
}

const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const normalise = (a) => { const n = Math.hypot(...a); return a.map((v) => v / n); };

// Back-to-front order by depth along the view axis: a counting sort on 16-bit depths.
function sortSplats(b) {
  const n = scene.count;
  const forward = b.back.map((v) => -v);
  const depth = new Float32Array(n);
  let lo = Infinity;
  let hi = -Infinity;
  for (let i = 0; i < n; i++) {
    const d = (scene.means[3 * i] - b.eye[0]) * forward[0] + (scene.means[3 * i + 1] - b.eye[1]) * forward[1]
      + (scene.means[3 * i + 2] - b.eye[2]) * forward[2];
    depth[i] = d;
    if (d < lo) lo = d;
    if (d > hi) hi = d;
  }
  const buckets = 65536;
  const scale = (buckets - 1) / Math.max(hi - lo, 1e-9);
  const counts = new Uint32Array(buckets);
  const keys = new Uint16Array(n);
  for (let i = 0; i < n; i++) {
    keys[i] = (buckets - 1) - Math.floor((depth[i] - lo) * scale);
    counts[keys[i]]++;
  }
  for (let k = 1; k < buckets; k++) counts[k] += counts[k - 1];
  for (let i = n - 1; i >= 0; i--) indices[--counts[keys[i]]] = i;
  gl.bindBuffer(gl.ARRAY_BUFFER, indexBuffer);
  gl.bufferSubData(gl.ARRAY_BUFFER, 0, indices);
}

function draw() {
  const started = performance.now();
  dirty = false;
  const b = basis();
  sortSplats(b);
  const w = canvas.width;
  const h = canvas.height;
  const f = 0.5 * h / Math.tan(0.5 * camera.fov * Math.PI / 180);
  // World to camera with y down and z forward: rows right, −up, −back.
  const rows = [b.right, b.up.map((v) => -v), b.back.map((v) => -v)];
  gl.viewport(0, 0, w, h);
  gl.clearColor(scene.background[0], scene.background[1], scene.background[2], 1);
  gl.clear(gl.COLOR_BUFFER_BIT);
  gl.useProgram(program);
  // Column-major upload of the row-major matrix.
  gl.uniformMatrix3fv(gl.getUniformLocation(program, 'u_rotation'), true, rows.flat());
  gl.uniform3fv(gl.getUniformLocation(program, 'u_eye'), b.eye);
  gl.uniform4f(gl.getUniformLocation(program, 'u_intrinsics'), f, f, 0.5 * w, 0.5 * h);
  gl.uniform2f(gl.getUniformLocation(program, 'u_size'), w, h);
  gl.uniform2f(gl.getUniformLocation(program, 'u_limits'), 1.3 * 0.5 * w / f, 1.3 * 0.5 * h / f);
  gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 4, scene.count);
  gl.finish();
  drawMs = performance.now() - started;
}

// Shows the canvas as large as the window allows, at its own aspect ratio.
function fit() {
  const s = Math.min(0.96 * innerWidth / canvas.width, 0.88 * innerHeight / canvas.height);
  canvas.style.width = `${Math.floor(canvas.width * s)}px`;
  canvas.style.height = `${Math.floor(canvas.height * s)}px`;
}

function frame() {
  if (dirty && program) draw();
  requestAnimationFrame(frame);
}

// A camera from the URL's hash: `#c2w=16 numbers (row-major)&fov=vertical degrees&w=&h=`, so a
// view can be linked and compared.
function cameraFromHash() {
  const q = new URLSearchParams(location.hash.slice(1));
  if (q.has('w') && q.has('h')) { canvas.width = parseInt(q.get('w'), 10); canvas.height = parseInt(q.get('h'), 10); }
  if (q.has('fov')) camera.fov = parseFloat(q.get('fov'));
  if (q.has('c2w')) {
    const m = q.get('c2w').split(',').map(Number);
    camera.fixed = { right: [m[0], m[4], m[8]], up: [m[1], m[5], m[9]], back: [m[2], m[6], m[10]], eye: [m[3], m[7], m[11]] };
  }
}

function setupInput() {
  let drag = null;
  canvas.addEventListener('contextmenu', (e) => e.preventDefault());
  canvas.addEventListener('pointerdown', (e) => { canvas.setPointerCapture(e.pointerId); drag = { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey }; });
  canvas.addEventListener('pointerup', () => { drag = null; });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x;
    const dy = e.clientY - drag.y;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (camera.fixed) camera.fixed = null;
    if (drag.pan) {
      const b = basis();
      const k = 2 * Math.tan(0.5 * camera.fov * Math.PI / 180) * camera.dist / canvas.getBoundingClientRect().height;
      camera.target = camera.target.map((v, i) => v - dx * k * b.right[i] + dy * k * b.up[i]);
    } else {
      camera.yaw -= dx * 0.008;
      camera.pitch = Math.max(-1.55, Math.min(1.55, camera.pitch + dy * 0.008));
    }
    dirty = true;
  });
  canvas.addEventListener('wheel', (e) => { e.preventDefault(); camera.fixed = null; camera.dist *= Math.exp(0.0015 * e.deltaY); dirty = true; }, { passive: false });
}

async function main() {
  if (!gl) { status.textContent = 'this browser has no WebGL2'; return; }
  const meta = await (await fetch('scene.json')).json();
  const buffer = await (await fetch('splats.bin')).arrayBuffer();
  if (buffer.byteLength !== meta.count * meta.bytes_per_splat) {
    status.textContent = `splats.bin holds ${buffer.byteLength} bytes, not ${meta.count} splats`;
    return;
  }
  const decoded = decode(buffer, meta.count);
  Object.assign(scene, { count: meta.count, means: decoded.means, background: meta.background });
  camera.target = meta.centre.slice();
  camera.dist = meta.radius;
  camera.fov = meta.fov_y_degrees;
  canvas.width = meta.width;
  canvas.height = meta.height;
  cameraFromHash();
  fit();
  window.addEventListener('resize', fit);
  window.addEventListener('hashchange', () => { cameraFromHash(); fit(); dirty = true; });

  program = gl.createProgram();
  gl.attachShader(program, compile(gl.VERTEX_SHADER, VERTEX));
  gl.attachShader(program, compile(gl.FRAGMENT_SHADER, FRAGMENT));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));

  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, decoded.width, decoded.rows, 0, gl.RGBA, gl.FLOAT, decoded.data);
  for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, p, gl.NEAREST);

  const vao = gl.createVertexArray();
  gl.bindVertexArray(vao);
  const corners = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, corners);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
  const corner = gl.getAttribLocation(program, 'a_corner');
  gl.enableVertexAttribArray(corner);
  gl.vertexAttribPointer(corner, 2, gl.FLOAT, false, 0, 0);
  indices = new Uint32Array(meta.count);
  indexBuffer = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, indexBuffer);
  gl.bufferData(gl.ARRAY_BUFFER, indices, gl.DYNAMIC_DRAW);
  const index = gl.getAttribLocation(program, 'a_index');
  gl.enableVertexAttribArray(index);
  gl.vertexAttribIPointer(index, 1, gl.UNSIGNED_INT, 0, 0);
  gl.vertexAttribDivisor(index, 1);

  gl.enable(gl.BLEND);
  gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
  gl.disable(gl.DEPTH_TEST);
  setupInput();
  status.textContent = `${meta.count.toLocaleString()} Gaussians · drag to orbit, right-drag to pan, wheel to zoom`;
  dirty = true;
  requestAnimationFrame(frame);
  document.body.dataset.ready = 'true';
}

main().catch((e) => { status.textContent = String(e.message || e); });
