// lumen view: a session's wall, scope and contacts, drawn with WebGL2 from the stream of
// view/README.md (a scene message, then binary frames carrying only the wall rows that changed).
"use strict";
(function () {
  const canvas = document.getElementById("gl");
  const gl = canvas.getContext("webgl2", { antialias: false, xrCompatible: true, preserveDrawingBuffer: true });
  const $ = (id) => document.getElementById(id);
  const view = (window.lumenView = { ready: false, frames: 0, stats: null, scene: null, viewProj: null, width: 0, height: 0, tip: null, contacts: [], bytes: 0, timing: null, xrFrames: 0, xrModel: null, error: null });
  if (!gl) { view.error = "no WebGL2"; document.body.insertAdjacentHTML("beforeend", "<p style='position:absolute;top:40%;width:100%;text-align:center'>This browser has no WebGL2.</p>"); return; }

  // ---- shaders: one lit program (position, normal, colour per vertex) for every mesh
  const VS = `#version 300 es
  in vec3 p; in vec3 n; in vec4 c; uniform mat4 vp; uniform mat4 model; out vec3 vn; out vec4 vc;
  void main() { gl_Position = vp * model * vec4(p, 1.0); vn = n; vc = c; }`;
  const FS = `#version 300 es
  precision highp float; in vec3 vn; in vec4 vc; uniform float lit; out vec4 o;
  void main() { float d = length(vn) > 0.0 ? abs(dot(normalize(vn), normalize(vec3(0.4, 0.7, 0.6)))) : 1.0;
    o = vec4(vc.rgb * mix(1.0, 0.35 + 0.65 * d, lit), vc.a); }`;
  function shader(kind, src) { const s = gl.createShader(kind); gl.shaderSource(s, src); gl.compileShader(s); if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s)); return s; }
  const prog = gl.createProgram();
  gl.attachShader(prog, shader(gl.VERTEX_SHADER, VS)); gl.attachShader(prog, shader(gl.FRAGMENT_SHADER, FS));
  gl.bindAttribLocation(prog, 0, "p"); gl.bindAttribLocation(prog, 1, "n"); gl.bindAttribLocation(prog, 2, "c");
  gl.linkProgram(prog);
  const U = { vp: gl.getUniformLocation(prog, "vp"), model: gl.getUniformLocation(prog, "model"), lit: gl.getUniformLocation(prog, "lit") };

  // A mesh: interleaved-free buffers of positions, normals, colours and optional indices.
  function mesh() {
    const m = { vao: gl.createVertexArray(), p: gl.createBuffer(), n: gl.createBuffer(), c: gl.createBuffer(), i: gl.createBuffer(), count: 0, indexed: false };
    gl.bindVertexArray(m.vao);
    [[m.p, 0, 3], [m.n, 1, 3], [m.c, 2, 4]].forEach(([b, loc, k]) => { gl.bindBuffer(gl.ARRAY_BUFFER, b); gl.enableVertexAttribArray(loc); gl.vertexAttribPointer(loc, k, gl.FLOAT, false, 0, 0); });
    gl.bindVertexArray(null);
    return m;
  }
  function upload(m, pos, nor, col, idx) {
    gl.bindVertexArray(m.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, m.p); gl.bufferData(gl.ARRAY_BUFFER, pos, gl.DYNAMIC_DRAW);
    gl.bindBuffer(gl.ARRAY_BUFFER, m.n); gl.bufferData(gl.ARRAY_BUFFER, nor, gl.DYNAMIC_DRAW);
    if (col) { gl.bindBuffer(gl.ARRAY_BUFFER, m.c); gl.bufferData(gl.ARRAY_BUFFER, col, gl.DYNAMIC_DRAW); }
    if (idx) { gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, m.i); gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, idx, gl.STATIC_DRAW); m.count = idx.length; m.indexed = true; }
    else if (!m.indexed) m.count = pos.length / 3;
    gl.bindVertexArray(null);
  }

  // ---- small vector and matrix helpers (column-major 4x4, as WebGL takes them)
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const len = (a) => Math.hypot(a[0], a[1], a[2]);
  const unit = (a) => { const l = len(a); return l > 0 ? mul(a, 1 / l) : [0, 0, 1]; };
  function mat4mul(a, b) { const o = new Float32Array(16); for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) { let s = 0; for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k]; o[c * 4 + r] = s; } return o; }
  function perspective(fovy, aspect, near, far) { const f = 1 / Math.tan(fovy / 2), o = new Float32Array(16); o[0] = f / aspect; o[5] = f; o[10] = (far + near) / (near - far); o[11] = -1; o[14] = (2 * far * near) / (near - far); return o; }
  function lookAt(eye, at, up) { const z = unit(sub(eye, at)), x = unit(cross(up, z)), y = cross(z, x);
    return new Float32Array([x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -(x[0] * eye[0] + x[1] * eye[1] + x[2] * eye[2]), -(y[0] * eye[0] + y[1] * eye[1] + y[2] * eye[2]), -(z[0] * eye[0] + z[1] * eye[1] + z[2] * eye[2]), 1]); }
  const IDENTITY = new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);

  // ---- scene state
  let scene = null, walls = [], rods = [], contactMesh = mesh(), arrowMesh = mesh();
  const cam = { target: [0, 0, 0], dist: 500, yaw: 0.6, pitch: 0.5, fitted: false };
  const history = [];
  let shownTimes = [], dropped = 0;

  function onScene(s) {
    scene = view.scene = s; walls = []; rods = []; view.frames = 0; cam.fitted = false; dropped = 0;
    $("session").textContent = String(s.session);
    s.bodies.forEach((b, i) => {
      if (b.kind === "tube") {
        const n = b.rows * b.spokes, idx = new Uint32Array((b.rows - 1) * b.spokes * 6);
        let o = 0;
        for (let r = 0; r + 1 < b.rows; r++) for (let k = 0; k < b.spokes; k++) {
          const a = r * b.spokes + k, c = r * b.spokes + ((k + 1) % b.spokes), d = a + b.spokes, e = c + b.spokes;
          idx[o++] = a; idx[o++] = d; idx[o++] = c; idx[o++] = c; idx[o++] = d; idx[o++] = e;
        }
        const col = new Float32Array(n * 4); for (let v = 0; v < n; v++) col.set([0.93, 0.6, 0.58, 0.38], v * 4);
        const m = mesh(); const w = { body: i, info: b, pos: new Float32Array(n * 3), nor: new Float32Array(n * 3), mesh: m };
        upload(m, w.pos, w.nor, col, idx); walls.push(w);
      } else rods.push({ body: i, info: b, mesh: mesh(), points: [] });
    });
    if (s.source === "recording") { $("playback").style.display = "block"; $("scrub").max = String(Math.max(0, s.frames - 1)); }
  }

  function wallNormals(w, r0, r1) {
    const { rows, spokes } = w.info, P = w.pos, N = w.nor;
    const at = (r, k) => { const j = (Math.min(Math.max(r, 0), rows - 1) * spokes + ((k + spokes) % spokes)) * 3; return [P[j], P[j + 1], P[j + 2]]; };
    for (let r = Math.max(0, r0); r < Math.min(rows, r1); r++) for (let k = 0; k < spokes; k++) {
      const n = unit(cross(sub(at(r + 1, k), at(r - 1, k)), sub(at(r, k + 1), at(r, k - 1))));
      N.set(n, (r * spokes + k) * 3);
    }
  }

  function depthColour(depth, flags) {
    if (flags & 2) return [1, 0, 1, 1];
    const t = Math.min(Math.max(depth / 2, 0), 1);
    return [1, 0.9 * (1 - t), 0, 1];
  }

  function tubeAround(points, radius, ring, out, nor) {
    for (let j = 0; j < points.length; j++) {
      const p = points[j], q = points[Math.min(j + 1, points.length - 1)], pr = points[Math.max(j - 1, 0)];
      const t = unit(sub(q, pr)), a = unit(cross(t, Math.abs(t[2]) < 0.9 ? [0, 0, 1] : [1, 0, 0])), b = cross(t, a);
      const r = radius.length === 1 ? radius[0] : radius[j];
      for (let k = 0; k < ring; k++) { const th = (k / ring) * 2 * Math.PI, d = add(mul(a, Math.cos(th)), mul(b, Math.sin(th)));
        out.push(...add(p, mul(d, r))); nor.push(...d); }
    }
  }

  function onFrame(buf) {
    const t0 = performance.now();
    const dv = new DataView(buf);
    if (dv.getUint32(0, true) !== 0x57564d4c || !scene) return;
    const jl = dv.getUint32(4, true);
    const msg = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 8, jl)));
    const f = new Float32Array(buf, 8 + jl);
    let o = 0;
    for (const blk of msg.walls) {
      const w = walls.find((x) => x.body === blk.body); const n = blk.rows * w.info.spokes * 3;
      w.pos.set(f.subarray(o, o + n), blk.first_row * w.info.spokes * 3); o += n;
      wallNormals(w, blk.first_row - 1, blk.first_row + blk.rows + 1); w.dirty = true;
    }
    for (const blk of msg.rods) {
      const r = rods.find((x) => x.body === blk.body); r.points = [];
      for (let j = 0; j < blk.points; j++) { r.points.push([f[o], f[o + 1], f[o + 2]]); o += 3; }
    }
    const contacts = [];
    for (let j = 0; j < msg.contacts; j++, o += 8) contacts.push({ point: [f[o], f[o + 1], f[o + 2]], normal: [f[o + 3], f[o + 4], f[o + 5]], depth: f[o + 6], flags: f[o + 7] });
    view.contacts = contacts; view.stats = msg.stats; view.frames++; dropped += msg.dropped;
    const last = rods.length ? rods[rods.length - 1].points : [];
    view.tip = last.length ? last[last.length - 1] : null;
    const t1 = performance.now(); rebuild(); const t2 = performance.now(); panel(msg.stats); history.push([msg.stats.max_depth, msg.stats.detect_us]); if (history.length > 230) history.shift();
    if (!cam.fitted) fit();
    draw(); view.ready = true; view.bytes += buf.byteLength;
    view.timing = { decode_ms: t1 - t0, build_ms: t2 - t1, draw_ms: performance.now() - t2 };
    // Held: the picture stays on this frame, and the server sends nothing more until released.
    if ($("hold").checked) waiting = true; else sock.send(JSON.stringify({ op: "ready" }));
  }
  let waiting = false;
  $("hold").addEventListener("change", () => { if (!$("hold").checked && waiting && sock && sock.readyState === 1) { waiting = false; sock.send(JSON.stringify({ op: "ready" })); } });

  function rebuild() {
    for (const w of walls) if (w.dirty) { upload(w.mesh, w.pos, w.nor, null, null); w.dirty = false; }
    for (const r of rods) { const p = [], n = [], c = [], idx = [], ring = 12;
      tubeAround(r.points, r.info.radius, ring, p, n);
      for (let v = 0; v < p.length / 3; v++) c.push(0.24, 0.5, 1.0, 1);
      for (let j = 0; j + 1 < r.points.length; j++) for (let k = 0; k < ring; k++) { const a = j * ring + k, b = j * ring + ((k + 1) % ring); idx.push(a, a + ring, b, b, a + ring, b + ring); }
      r.mesh.indexed = false; upload(r.mesh, new Float32Array(p), new Float32Array(n), new Float32Array(c), new Uint32Array(idx)); }
    // Contacts: an octahedron at the wall point; an arrow (line) along the normal.
    const p = [], n = [], c = [], lp = [], ln = [], lc = [];
    const s = 1.6, dirs = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];
    for (const k of view.contacts) { const col = depthColour(k.depth, k.flags);
      for (const [a, b, d] of [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
        for (const v of [a, b, d]) { p.push(...add(k.point, mul(dirs[v], s))); n.push(0, 0, 0); c.push(...col); }
      const l = 3 + 6 * Math.max(k.depth, 0); lp.push(...k.point, ...add(k.point, mul(k.normal, -l))); ln.push(0, 0, 0, 0, 0, 0); lc.push(...col, ...col); }
    contactMesh.indexed = false; upload(contactMesh, new Float32Array(p), new Float32Array(n), new Float32Array(c), null);
    arrowMesh.indexed = false; upload(arrowMesh, new Float32Array(lp), new Float32Array(ln), new Float32Array(lc), null);
  }

  function fit() {
    let lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    for (const w of walls) for (let j = 0; j < w.pos.length; j += 3) for (let a = 0; a < 3; a++) { lo[a] = Math.min(lo[a], w.pos[j + a]); hi[a] = Math.max(hi[a], w.pos[j + a]); }
    if (!isFinite(lo[0])) return;
    cam.target = mul(add(lo, hi), 0.5); cam.dist = 1.2 * len(sub(hi, lo)) + 1; cam.fitted = true; view.bounds = [lo, hi];
  }

  function cameraMatrices(aspect) {
    let eye, at, up = [0, 0, 1], near = cam.dist / 500, far = cam.dist * 4;
    const scopeView = $("scopecam").checked && rods.length && rods[rods.length - 1].points.length > 1;
    if (scopeView) { const pts = rods[rods.length - 1].points, tip = pts[pts.length - 1], prev = pts[pts.length - 2];
      const dir = unit(sub(tip, prev)); eye = tip; at = add(tip, dir); up = Math.abs(dir[2]) < 0.9 ? [0, 0, 1] : [0, 1, 0]; near = 0.5; far = cam.dist * 2; }
    else { if ($("follow").checked && view.tip) cam.target = view.tip;
      const d = [Math.cos(cam.pitch) * Math.cos(cam.yaw), Math.cos(cam.pitch) * Math.sin(cam.yaw), Math.sin(cam.pitch)];
      eye = add(cam.target, mul(d, cam.dist)); at = cam.target; }
    return mat4mul(perspective(scopeView ? 1.6 : 0.8, aspect, near, far), lookAt(eye, at, up));
  }

  function drawScene(vp, model) {
    gl.useProgram(prog); gl.uniformMatrix4fv(U.vp, false, vp); gl.uniformMatrix4fv(U.model, false, model);
    const go = (m, mode) => { if (!m.count) return; gl.bindVertexArray(m.vao); if (m.indexed) gl.drawElements(mode, m.count, gl.UNSIGNED_INT, 0); else gl.drawArrays(mode, 0, m.count); };
    gl.enable(gl.DEPTH_TEST); gl.depthMask(true); gl.disable(gl.BLEND); gl.uniform1f(U.lit, 1);
    for (const r of rods) go(r.mesh, gl.TRIANGLES);
    // The wall over the scope, see-through; contacts over both, so a press is never hidden.
    gl.enable(gl.BLEND); gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA); gl.depthMask(false);
    if ($("wall").checked) for (const w of walls) go(w.mesh, gl.TRIANGLES);
    gl.disable(gl.DEPTH_TEST); gl.uniform1f(U.lit, 0);
    go(contactMesh, gl.TRIANGLES); go(arrowMesh, gl.LINES);
    gl.depthMask(true); gl.bindVertexArray(null);
  }

  function draw() {
    if (xrSession) return;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    gl.bindFramebuffer(gl.FRAMEBUFFER, null); gl.viewport(0, 0, w, h);
    gl.clearColor(0.078, 0.086, 0.118, 1); gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    const vp = cameraMatrices(w / Math.max(h, 1)); view.viewProj = Array.from(vp); view.width = w; view.height = h;
    drawScene(vp, IDENTITY);
  }

  function fmt(x, d) { return x === null || x === undefined ? "-" : Number(x).toFixed(d); }
  function panel(s) {
    const now = performance.now(); shownTimes.push(now); while (shownTimes.length && now - shownTimes[0] > 1000) shownTimes.shift();
    $("frame").textContent = String(s.frame); $("fps").textContent = fmt(s.fps, 1); $("turnaround").textContent = fmt(s.turnaround_us, 0);
    $("detect").textContent = fmt(s.detect_us, 0); $("contacts").textContent = String(s.contacts); $("maxpen").textContent = fmt(s.max_depth, 3);
    $("escaped").textContent = String(s.escaped); $("shownfps").textContent = String(shownTimes.length); $("dropped").textContent = String(dropped);
    if (s.index !== null && s.index !== undefined) { $("index").textContent = String(s.index); if (document.activeElement !== $("scrub")) $("scrub").value = String(s.index); }
    const c = $("plot").getContext("2d"), W = c.canvas.width, H = c.canvas.height; c.clearRect(0, 0, W, H);
    const maxP = Math.max(1, ...history.map((x) => x[0])), maxD = Math.max(1, ...history.map((x) => x[1]));
    [[0, maxP, "#f44"], [1, maxD, "#4dd"]].forEach(([k, m, col]) => { c.strokeStyle = col; c.beginPath(); history.forEach((x, i) => { const y = H - 2 - (x[k] / m) * (H - 4); i ? c.lineTo(i, y) : c.moveTo(i, y); }); c.stroke(); });
  }

  // ---- mouse: orbit (left), pan (right or shift), zoom (wheel)
  let drag = null;
  canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  canvas.addEventListener("mousedown", (e) => { drag = { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey }; });
  window.addEventListener("mouseup", () => { drag = null; });
  window.addEventListener("mousemove", (e) => { if (!drag) return; const dx = e.clientX - drag.x, dy = e.clientY - drag.y; drag.x = e.clientX; drag.y = e.clientY;
    if (drag.pan) { const s = cam.dist / 800, r = [-Math.sin(cam.yaw), Math.cos(cam.yaw), 0]; cam.target = add(cam.target, add(mul(r, -dx * s), [0, 0, dy * s])); }
    else { cam.yaw -= dx * 0.01; cam.pitch = Math.max(-1.55, Math.min(1.55, cam.pitch + dy * 0.01)); } draw(); });
  canvas.addEventListener("wheel", (e) => { e.preventDefault(); cam.dist *= Math.exp(e.deltaY * 0.001); draw(); }, { passive: false });
  ["follow", "scopecam", "wall"].forEach((id) => $(id).addEventListener("change", draw));

  // ---- playback of a recording: every control goes to the server, which plays the file
  const send = (o) => sock && sock.readyState === 1 && sock.send(JSON.stringify(o));
  $("play").onclick = () => send({ op: "play" }); $("pause").onclick = () => send({ op: "pause" });
  $("step").onclick = () => send({ op: "step", by: 1 }); $("back").onclick = () => send({ op: "step", by: -1 });
  $("speed").onchange = () => send({ op: "speed", speed: Number($("speed").value) });
  $("scrub").addEventListener("input", () => send({ op: "seek", index: Number($("scrub").value) }));

  // ---- WebXR: the colon at room scale around the viewer, the same contacts
  let xrSession = null;
  if (navigator.xr && navigator.xr.isSessionSupported) {
    navigator.xr.isSessionSupported("immersive-vr").then((ok) => { if (ok) $("enter-vr").style.display = "block"; view.xr = ok; }).catch(() => {});
  }
  $("enter-vr").onclick = async () => {
    try {
      xrSession = await navigator.xr.requestSession("immersive-vr", { optionalFeatures: ["local-floor"] });
      await gl.makeXRCompatible(); xrSession.updateRenderState({ baseLayer: new XRWebGLLayer(xrSession, gl) });
      const space = await xrSession.requestReferenceSpace("local-floor").catch(() => xrSession.requestReferenceSpace("local"));
      xrSession.addEventListener("end", () => { xrSession = null; draw(); });
      const onXR = (t, xf) => { xrSession && xrSession.requestAnimationFrame(onXR); const pose = xf.getViewerPose(space); if (!pose || !view.bounds) return;
        const layer = xrSession.renderState.baseLayer; gl.bindFramebuffer(gl.FRAMEBUFFER, layer.framebuffer); gl.clearColor(0.05, 0.05, 0.08, 1); gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
        // mm to a 4 m wide room, centred on the viewer at eye height, z up turned to y up.
        const [lo, hi] = view.bounds, c = mul(add(lo, hi), 0.5), s = 4 / Math.max(1, len(sub(hi, lo)));
        const model = new Float32Array([s, 0, 0, 0, 0, 0, -s, 0, 0, s, 0, 0, -c[0] * s, -c[2] * s, c[1] * s + 0, 1]); model[13] += 1.4;
        for (const v of pose.views) { const vpt = layer.getViewport(v); gl.viewport(vpt.x, vpt.y, vpt.width, vpt.height); drawScene(mat4mul(v.projectionMatrix, v.transform.inverse.matrix), model); }
        view.xrModel = Array.from(model); view.xrFrames++; };
      xrSession.requestAnimationFrame(onXR);
    } catch (e) { view.error = "VR: " + e; }
  };

  // ---- the socket
  let sock = null;
  function connect() {
    sock = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/ws");
    sock.binaryType = "arraybuffer";
    sock.onmessage = (e) => { try { if (typeof e.data === "string") { const m = JSON.parse(e.data); if (m.type === "scene") onScene(m); } else onFrame(e.data); } catch (err) { view.error = String(err); console.error(err); } };
    sock.onclose = () => setTimeout(connect, 1000);
  }
  window.addEventListener("resize", draw);
  connect();
})();
