// view_app.js: the viewer of a `dtx view` page (src/io/html_view.h).  It
// runs after three.js in the page's one module script, with three's exports
// in THREE.  Everything it shows of the data goes in through textContent.
(async function () {
  'use strict';
  const data = JSON.parse(document.getElementById('dtx-data').textContent);
  const pick = data.mode === 'pick';

  // ------------------------------------------------------------ helpers
  function bytes(id) {
    const s = document.getElementById(id).textContent;
    const bin = atob(s);
    const u = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) u[i] = bin.charCodeAt(i);
    return u.buffer;
  }
  function el(tag, parent, text, cls) {
    const e = document.createElement(tag);
    if (text !== undefined && text !== null) e.textContent = String(text);
    if (cls) e.className = cls;
    if (parent) parent.appendChild(e);
    return e;
  }
  function control(parent, label, tag, type) {
    const l = el('label', parent, label ? label + ' ' : '');
    const c = el(tag, l);
    if (type) c.type = type;
    return c;
  }
  function fmt(x) { return x === null || x === undefined ? 'n/a' : Number(x).toPrecision(3); }

  // ------------------------------------------------------------ layout
  const app = document.getElementById('dtx-app');
  const bar = el('div', app); bar.id = 'dtx-bar';
  const body = el('div', app); body.id = 'dtx-body';
  const view = el('div', body); view.id = 'dtx-view';
  el('span', bar, data.file, 'dtx-file');
  document.title = 'dtx view: ' + data.file;

  // ------------------------------------------------------------ report
  // The Markdown of `dtx report` below the player: headings, list items,
  // tables and paragraphs made with textContent (no markup from the text is
  // ever interpreted); `code` spans shown as code.
  if (data.report) {
    app.className = 'dtx-with-report';
    const rep = el('div', app); rep.id = 'dtx-report';
    const inline = function (parent, text) {
      text.split('`').forEach(function (part, k) { if (part) el(k % 2 ? 'code' : 'span', parent, part); });
    };
    let table = null, list = null;
    data.report.split('\n').forEach(function (line) {
      const h = /^(#{1,4}) (.*)$/.exec(line);
      if (!/^\|/.test(line)) table = null;
      if (!/^- /.test(line)) list = null;
      if (h) el('h' + Math.min(4, h[1].length + 1), rep, h[2]);
      else if (/^\|/.test(line)) {
        if (/^\|[-| :]+\|$/.test(line)) return;
        const head = !table;
        if (!table) table = el('table', rep);
        const tr = el('tr', table);
        line.replace(/^\||\|$/g, '').split(/(?<!\\)\|/).forEach(function (c) { inline(el(head ? 'th' : 'td', tr), c.trim().replace(/\\\|/g, '|')); });
      } else if (/^- /.test(line)) {
        if (!list) list = el('ul', rep);
        inline(el('li', list), line.slice(2));
      } else if (/^!\[/.test(line) || line.trim() === '') {
        return;
      } else inline(el('p', rep), line);
    });
  }

  // Frames: 16-bit steps over the pane's box, each frame stored as its
  // difference to the one before (modulo 2^16), low bytes then high bytes,
  // gzip (html_view.h).
  async function frames(p) {
    const s = new Blob([bytes(p.frames)]).stream().pipeThrough(new DecompressionStream('gzip'));
    const u8 = new Uint8Array(await new Response(s).arrayBuffer());
    const n = u8.length / 2, per = p.nv * 3, q = new Uint16Array(n);
    for (let k = 0; k < n; k++) q[k] = u8[k] | (u8[n + k] << 8);
    for (let k = per; k < n; k++) q[k] = (q[k] + q[k - per]) & 0xffff;
    return q;
  }
  const decoded = await Promise.all(data.panes.map(function (p) { return p.nframes > 0 ? frames(p) : null; }));

  // ------------------------------------------------------------ panes
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  view.appendChild(renderer.domElement);
  const camera = new THREE.PerspectiveCamera(35, 1, 0.01, 100);
  let radius = 0;
  const panes = data.panes.map(function (p, i) {
    const faces = new Uint32Array(bytes(p.faces));
    const rest = new Float32Array(bytes(p.rest));
    const q = decoded[i];
    const pos = new Float32Array(rest);
    const geom = new THREE.BufferGeometry();
    geom.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    geom.setAttribute('color', new THREE.BufferAttribute(new Float32Array(pos.length).fill(0.75), 3));
    geom.setIndex(new THREE.BufferAttribute(faces, 1));
    geom.computeVertexNormals();
    geom.computeBoundingBox();
    const centre = geom.boundingBox.getCenter(new THREE.Vector3());
    radius = Math.max(radius, geom.boundingBox.getSize(new THREE.Vector3()).length() / 2);
    const mat = new THREE.MeshStandardMaterial({ color: 0xffffff, vertexColors: true, roughness: 0.8, metalness: 0.0, side: THREE.DoubleSide });
    const mesh = new THREE.Mesh(geom, mat);
    mesh.position.copy(centre).multiplyScalar(-1);
    const scene = new THREE.Scene();
    scene.background = new THREE.Color(i % 2 ? 0x2b2e35 : 0x272a30);
    scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.8);
    scene.add(sun);
    scene.add(mesh);
    const balls = new THREE.Group();
    balls.position.copy(mesh.position);
    scene.add(balls);
    const title = el('div', view, p.title, 'dtx-title');
    const sub = el('div', view, '', 'dtx-sub');
    if (p.info) title.title = p.info;
    return { p: p, i: i, q: q, pos: pos, geom: geom, mesh: mesh, mat: mat, scene: scene, sun: sun,
             balls: balls, title: title, sub: sub, frameShown: -1 };
  });

  // ------------------------------------------------------------ camera
  const home = { dist: radius * 3.2, theta: 0.6, phi: 1.3 };
  const orbit = { target: new THREE.Vector3(), dist: home.dist, theta: home.theta, phi: home.phi };
  // Far enough for the largest mesh to fit a pane of either shape.
  function homeDistance() {
    const r = paneRect(0), aspect = r.w / Math.max(1, r.h);
    return radius * 1.1 / Math.tan(camera.fov * Math.PI / 360) / Math.min(1, aspect);
  }
  function resetView() {
    home.dist = homeDistance();
    orbit.target.set(0, 0, 0);
    orbit.dist = home.dist; orbit.theta = home.theta; orbit.phi = home.phi;
    placeCamera();
  }
  function placeCamera() {
    // Never straight up or down, where lookAt has no defined roll.
    orbit.phi = Math.max(0.02, Math.min(Math.PI - 0.02, orbit.phi));
    const s = Math.sin(orbit.phi);
    camera.position.set(orbit.target.x + orbit.dist * s * Math.sin(orbit.theta),
                        orbit.target.y + orbit.dist * Math.cos(orbit.phi),
                        orbit.target.z + orbit.dist * s * Math.cos(orbit.theta));
    camera.near = Math.max(orbit.dist * 0.01, radius * 1e-4);
    camera.far = orbit.dist + radius * 4;
    camera.lookAt(orbit.target);
    camera.updateProjectionMatrix();
    camera.updateMatrixWorld();
    panes.forEach(function (P) { P.sun.position.copy(camera.position); });
    dirty = true;
  }
  let dirty = true;

  function paneRect(i) {
    const w = view.clientWidth / panes.length, h = view.clientHeight;
    return { x: i * w, y: 0, w: w, h: h };
  }
  function resize() {
    renderer.setSize(view.clientWidth, view.clientHeight);
    panes.forEach(function (P, i) {
      const r = paneRect(i);
      P.title.style.left = (r.x + 4) + 'px';
      P.sub.style.left = (r.x + 4) + 'px';
      P.title.style.maxWidth = P.sub.style.maxWidth = Math.max(0, r.w - 20) + 'px';
    });
    dirty = true;
  }

  // ------------------------------------------------------------ balls and labels
  const labelLayer = el('div', view);
  const ballGeom = new THREE.SphereGeometry(1, 16, 12);
  const ballMats = {
    src: new THREE.MeshBasicMaterial({ color: 0x3fa7ff }),
    tgt: new THREE.MeshBasicMaterial({ color: 0x5fdc5f }),
    key: new THREE.MeshBasicMaterial({ color: 0xffc83c }),
    pending: new THREE.MeshBasicMaterial({ color: 0xff4fd8 }),
    hot: new THREE.MeshBasicMaterial({ color: 0xff6a1e }),
  };
  let showLabels = pick;
  let balls = []; // {pane, v, kind, label, hot, obj, div}
  function clearBalls() {
    balls.forEach(function (b) { b.pane.balls.remove(b.obj); if (b.div) b.div.remove(); });
    balls = [];
  }
  function addBall(P, v, kind, label, hot) {
    const obj = new THREE.Mesh(ballGeom, hot ? ballMats.hot : ballMats[kind]);
    obj.userData.hot = hot;
    P.balls.add(obj);
    const b = { pane: P, v: v, obj: obj, div: null };
    if (label) b.div = el('div', labelLayer, label, 'dtx-label' + (hot ? ' dtx-hot' : ''));
    balls.push(b);
  }
  function placeBalls() {
    const w = new THREE.Vector3();
    // Balls keep about the same size on screen as the camera zooms in.
    const size = Math.min(radius * 0.011, orbit.dist * 0.004);
    balls.forEach(function (b) {
      const P = b.pane;
      b.obj.scale.setScalar(size * (b.obj.userData.hot ? 1.6 : 1));
      b.obj.position.set(P.pos[3 * b.v], P.pos[3 * b.v + 1], P.pos[3 * b.v + 2]);
      if (!b.div) return;
      b.div.style.display = showLabels ? '' : 'none';
      if (!showLabels) return;
      w.copy(b.obj.position).add(P.balls.position).project(camera);
      const r = paneRect(P.i);
      const vis = w.z < 1 && Math.abs(w.x) <= 1 && Math.abs(w.y) <= 1;
      b.div.style.display = vis ? '' : 'none';
      b.div.style.left = (r.x + (w.x + 1) / 2 * r.w) + 'px';
      b.div.style.top = (r.y + (1 - w.y) / 2 * r.h) + 'px';
    });
  }

  // ------------------------------------------------------------ drawing
  let firstFrameMs = null;
  function render() {
    resizeIfNeeded();
    placeBalls();
    renderer.setScissorTest(true);
    panes.forEach(function (P, i) {
      const r = paneRect(i);
      const y = view.clientHeight - r.y - r.h;
      renderer.setViewport(r.x, y, r.w, r.h);
      renderer.setScissor(r.x, y, r.w, r.h);
      camera.aspect = r.w / r.h;
      camera.updateProjectionMatrix();
      renderer.render(P.scene, camera);
    });
    if (firstFrameMs === null) firstFrameMs = performance.now();
  }
  let lastW = -1, lastH = -1;
  function resizeIfNeeded() {
    if (view.clientWidth !== lastW || view.clientHeight !== lastH) {
      lastW = view.clientWidth; lastH = view.clientHeight;
      resize();
    }
  }

  // ------------------------------------------------------------ frames
  const nframes = panes.reduce(function (m, P) { return Math.max(m, P.p.nframes); }, 0);
  const longest = panes.reduce(function (a, P) { return P.p.nframes > a.p.nframes ? P : a; }, panes[0]);
  let frame = 0;
  function setFrame(k) {
    frame = Math.max(0, Math.min(nframes - 1, k | 0));
    panes.forEach(function (P) {
      const p = P.p;
      if (!p.nframes) return;
      const f = Math.min(frame, p.nframes - 1);
      if (f === P.frameShown) return;
      const n = P.pos.length, off = f * n, lo = p.lo, st = p.step;
      for (let j = 0; j < n; j += 3) {
        P.pos[j] = lo[0] + P.q[off + j] * st[0];
        P.pos[j + 1] = lo[1] + P.q[off + j + 1] * st[1];
        P.pos[j + 2] = lo[2] + P.q[off + j + 2] * st[2];
      }
      P.geom.attributes.position.needsUpdate = true;
      P.geom.computeVertexNormals();
      P.geom.computeBoundingSphere();
      P.geom.computeBoundingBox();
      P.frameShown = f;
      const res = p.residual ? p.residual[f] : null;
      P.sub.textContent = 'frame ' + p.frame[f] + (p.residual ? ', residual ' + fmt(res) : '');
    });
    colour();
    if (slider) slider.value = String(frame);
    if (frameText && nframes) frameText.textContent = 'frame ' + longest.p.frame[Math.min(frame, longest.p.nframes - 1)] + ' of 0..' + (data.fileFrames - 1);
    dirty = true;
  }

  // ------------------------------------------------------------ colour
  let colourMode = 'none';
  const ramp = [[0.23, 0.30, 0.75], [0.87, 0.87, 0.87], [0.71, 0.02, 0.15]];
  function rampAt(t, out, j) {
    t = Math.max(0, Math.min(1, t)) * 2;
    const a = t < 1 ? ramp[0] : ramp[1], b = t < 1 ? ramp[1] : ramp[2], u = t < 1 ? t : t - 1;
    out[j] = a[0] + (b[0] - a[0]) * u; out[j + 1] = a[1] + (b[1] - a[1]) * u; out[j + 2] = a[2] + (b[2] - a[2]) * u;
  }
  function partner(P) {
    if (!P.p.group) return null;
    return panes.find(function (Q) { return Q !== P && Q.p.group === P.p.group; }) || null;
  }
  function colour() {
    panes.forEach(function (P) {
      const c = P.geom.attributes.color.array, n = P.pos.length;
      if (colourMode === 'residual' && P.p.residual) {
        const r = P.p.residual.filter(function (x) { return x !== null; });
        const max = Math.max.apply(null, r.concat([0]));
        const f = Math.min(frame, P.p.nframes - 1);
        const t = max > 0 && P.p.residual[f] !== null ? P.p.residual[f] / max : 0;
        for (let j = 0; j < n; j += 3) rampAt(t, c, j);
      } else if (colourMode === 'distance' && partner(P)) {
        const Q = partner(P);
        let max = 0;
        const d = new Float32Array(n / 3);
        for (let j = 0; j < n; j += 3) {
          const dx = P.pos[j] - Q.pos[j], dy = P.pos[j + 1] - Q.pos[j + 1], dz = P.pos[j + 2] - Q.pos[j + 2];
          d[j / 3] = Math.sqrt(dx * dx + dy * dy + dz * dz);
          max = Math.max(max, d[j / 3]);
        }
        for (let j = 0; j < n; j += 3) rampAt(max > 0 ? d[j / 3] / max : 0, c, j);
        P.sub.textContent = P.sub.textContent.replace(/, largest distance .*$/, '') + ', largest distance ' + fmt(max) + ' to ' + Q.p.title;
      } else {
        c.fill(0.75);
      }
      P.geom.attributes.color.needsUpdate = true;
    });
    dirty = true;
  }

  // ------------------------------------------------------------ controls
  let slider = null, frameText = null, playing = false, speed = 1, loop = true;
  const fps = 24;
  if (nframes > 0) {
    const play = el('button', bar, 'Play');
    play.addEventListener('click', function () { playing = !playing; play.textContent = playing ? 'Pause' : 'Play'; last = performance.now(); });
    slider = control(bar, '', 'input', 'range');
    slider.min = '0'; slider.max = String(nframes - 1); slider.value = '0';
    slider.addEventListener('input', function () { setFrame(Number(slider.value)); });
    frameText = el('span', bar, '');
    const sp = control(bar, 'speed', 'select');
    [0.25, 0.5, 1, 2, 4].forEach(function (s) { const o = el('option', sp, s + 'x'); o.value = String(s); if (s === 1) o.selected = true; });
    sp.addEventListener('change', function () { speed = Number(sp.value); });
    const lp = control(bar, 'loop', 'input', 'checkbox');
    lp.checked = true;
    lp.addEventListener('change', function () { loop = lp.checked; });
    const cm = control(bar, 'colour', 'select');
    [['none', 'plain'], ['residual', 'frame residual'], ['distance', 'distance to the other result']].forEach(function (o) { const e = el('option', cm, o[1]); e.value = o[0]; });
    cm.addEventListener('change', function () { colourMode = cm.value; colour(); setFrame(frame); });
    el('span', bar, data.fileFrames + ' frames in the file, ' + nframes + ' in the page' +
       (data.stride > 1 ? ' (every ' + data.stride + 'th; budget --max-frames ' + data.maxFrames + ')' : ' (budget --max-frames ' + data.maxFrames + ')'), 'dtx-note');
  }
  el('button', bar, 'Reset view').addEventListener('click', resetView);
  const wf = control(bar, 'wireframe', 'input', 'checkbox');
  wf.addEventListener('change', function () { panes.forEach(function (P) { P.mat.wireframe = wf.checked; }); dirty = true; });
  const flat = control(bar, 'flat', 'input', 'checkbox');
  flat.addEventListener('change', function () { panes.forEach(function (P) { P.mat.flatShading = flat.checked; P.mat.needsUpdate = true; }); dirty = true; });
  const lb = control(bar, 'labels', 'input', 'checkbox');
  lb.checked = showLabels;
  lb.addEventListener('change', function () { showLabels = lb.checked; dirty = true; });

  let last = performance.now(), acc = 0;
  function tick(now) {
    if (playing && nframes > 1) {
      acc += (now - last) * fps * speed / 1000;
      const steps = Math.floor(acc);
      if (steps > 0) {
        acc -= steps;
        let k = frame + steps;
        if (k >= nframes) {
          if (loop) k %= nframes;
          else { k = nframes - 1; playing = false; }
        }
        setFrame(k);
      }
    }
    last = now;
    if (dirty) { dirty = false; render(); }
    requestAnimationFrame(tick);
  }

  // ------------------------------------------------------------ mouse
  const raycaster = new THREE.Raycaster();
  function paneAt(x, y) {
    const r = view.getBoundingClientRect();
    const lx = x - r.left, ly = y - r.top;
    for (let i = 0; i < panes.length; i++) {
      const pr = paneRect(i);
      if (lx >= pr.x && lx < pr.x + pr.w && ly >= 0 && ly < pr.h)
        return { P: panes[i], nx: (lx - pr.x) / pr.w * 2 - 1, ny: -(ly / pr.h * 2 - 1) };
    }
    return null;
  }
  // The vertex under client point (x, y): the corner of the triangle hit
  // nearest to the hit point.  null when nothing is hit.
  function vertexAt(x, y) {
    const a = paneAt(x, y);
    if (!a) return null;
    camera.aspect = paneRect(a.P.i).w / paneRect(a.P.i).h;
    camera.updateProjectionMatrix();
    raycaster.setFromCamera(new THREE.Vector2(a.nx, a.ny), camera);
    const hit = raycaster.intersectObject(a.P.mesh, false)[0];
    if (!hit) return null;
    const local = a.P.mesh.worldToLocal(hit.point.clone());
    let best = -1, bd = Infinity;
    [hit.face.a, hit.face.b, hit.face.c].forEach(function (v) {
      const dx = a.P.pos[3 * v] - local.x, dy = a.P.pos[3 * v + 1] - local.y, dz = a.P.pos[3 * v + 2] - local.z;
      const d = dx * dx + dy * dy + dz * dz;
      if (d < bd) { bd = d; best = v; }
    });
    return { pane: a.P.i, v: best };
  }
  let drag = null, lastClick = null;
  renderer.domElement.addEventListener('pointerdown', function (e) {
    drag = { x: e.clientX, y: e.clientY, moved: false, button: e.button, shift: e.shiftKey };
  });
  window.addEventListener('pointermove', function (e) {
    if (!drag) { if (pick && e.target === renderer.domElement) hover(vertexAt(e.clientX, e.clientY)); return; }
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    if (!drag.moved && Math.abs(dx) + Math.abs(dy) < 4) return;
    drag.moved = true;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.button === 2 || drag.shift) {
      const s = orbit.dist / view.clientHeight;
      const right = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0);
      const up = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 1);
      orbit.target.addScaledVector(right, -dx * s).addScaledVector(up, dy * s);
    } else {
      orbit.theta -= dx * 0.01;
      orbit.phi = Math.max(0.05, Math.min(Math.PI - 0.05, orbit.phi - dy * 0.01));
    }
    placeCamera();
  });
  window.addEventListener('pointerup', function (e) {
    const d = drag;
    drag = null;
    if (d && !d.moved && d.button === 0 && pick) {
      const h = vertexAt(e.clientX, e.clientY);
      lastClick = { x: e.clientX, y: e.clientY, pane: h ? h.pane : null, v: h ? h.v : null };
      if (h) clickVertex(h.pane, h.v);
    }
  });
  renderer.domElement.addEventListener('contextmenu', function (e) { e.preventDefault(); });
  renderer.domElement.addEventListener('wheel', function (e) {
    e.preventDefault();
    orbit.dist = Math.max(radius * 0.02, Math.min(radius * 50, orbit.dist * Math.exp(e.deltaY * 0.001)));
    placeCamera();
  }, { passive: false });

  // ------------------------------------------------------------ picking
  let pairs = [], pending = { s: null, t: null }, selected = -1, hot = -1;
  const undo = [];
  const side = pick ? el('div', body) : null;
  let listBody = null, status = null, labelInput = null;
  const keypoints = data.keypoints || null;
  function snapshot() { undo.push(JSON.stringify(pairs)); if (undo.length > 500) undo.shift(); }
  function say(t) { if (status) status.textContent = t; }
  function nextKeypoint() {
    if (!keypoints) return null;
    const used = new Set(pairs.map(function (p) { return p.s; }));
    const k = keypoints.vertex.findIndex(function (v) { return !used.has(v); });
    return k < 0 ? null : k;
  }
  function clickVertex(i, v) {
    if (selected >= 0) {
      snapshot();
      if (i === 0) pairs[selected].s = v; else pairs[selected].t = v;
      say('moved pair ' + (selected + 1) + (i === 0 ? ' source to ' : ' target to ') + v);
    } else {
      if (i === 0) pending.s = v; else pending.t = v;
      if (pending.s !== null && pending.t !== null) {
        snapshot();
        let label = labelInput.value;
        if (!label && keypoints) {
          const k = keypoints.vertex.indexOf(pending.s);
          if (k >= 0) label = keypoints.label[k];
        }
        pairs.push({ s: pending.s, t: pending.t, label: label });
        labelInput.value = '';
        say('pair ' + pairs.length + ': ' + pending.s + ' -> ' + pending.t);
        pending = { s: null, t: null };
        const k = nextKeypoint();
        if (k !== null) pending.s = keypoints.vertex[k];
      } else {
        say((i === 0 ? 'source ' : 'target ') + v + ': now click its partner');
      }
    }
    refresh();
  }
  function hover(h) {
    let k = -1;
    if (h) k = pairs.findIndex(function (p) { return h.pane === 0 ? p.s === h.v : p.t === h.v; });
    if (k !== hot) { hot = k; refresh(false); }
  }
  // The vertex of pane P nearest to vertex v reflected across the plane
  // through P's box centre normal to axis a (0, 1, 2).
  function mirrorVertex(P, v, a) {
    const c = -P.mesh.position.getComponent(a);
    const x = [P.pos[3 * v], P.pos[3 * v + 1], P.pos[3 * v + 2]];
    x[a] = 2 * c - x[a];
    let best = v, bd = Infinity;
    for (let j = 0; j < P.pos.length; j += 3) {
      const dx = P.pos[j] - x[0], dy = P.pos[j + 1] - x[1], dz = P.pos[j + 2] - x[2];
      const d = dx * dx + dy * dy + dz * dz;
      if (d < bd) { bd = d; best = j / 3; }
    }
    return best;
  }
  function csvLabel(s) {
    s = String(s).replace(/[\r\n]+/g, ' ');
    if (/[",]/.test(s) || s !== s.trim()) return '"' + s.replace(/"/g, '""') + '"';
    return s;
  }
  function csv() {
    let t = '# index_base: 0\nsource_vertex,target_vertex,label\n';
    pairs.forEach(function (p) { t += p.s + ',' + p.t + ',' + csvLabel(p.label) + '\n'; });
    return t;
  }
  // Balls (and list classes) from the state; the list's rows are rebuilt
  // only when the pairs change (list = true), so hovering a row never
  // replaces the element under the mouse.
  let rows = [];
  function refresh(list) {
    clearBalls();
    if (pick) {
      pairs.forEach(function (p, k) {
        const isHot = k === hot || k === selected;
        // Numbers on the balls (the list has the labels), the whole label on
        // the pair under the cursor or selected.
        const lab = String(k + 1) + (isHot && p.label ? ' ' + p.label : '');
        addBall(panes[0], p.s, 'src', lab, isHot);
        addBall(panes[1], p.t, 'tgt', lab, isHot);
      });
      if (keypoints) keypoints.vertex.forEach(function (v, k) {
        if (!pairs.some(function (p) { return p.s === v; })) addBall(panes[0], v, 'key', 'key ' + (k + 1) + (keypoints.label[k] ? ' ' + keypoints.label[k] : ''), false);
      });
      if (pending.s !== null) addBall(panes[0], pending.s, 'pending', 'next: ' + pending.s, false);
      if (pending.t !== null) addBall(panes[1], pending.t, 'pending', 'next: ' + pending.t, false);
      if (list !== false) {
        listBody.textContent = '';
        rows = pairs.map(function (p, k) {
          const tr = el('tr', listBody);
          el('td', tr, k + 1); el('td', tr, p.s); el('td', tr, p.t); el('td', tr, p.label);
          tr.addEventListener('click', function () { selected = selected === k ? -1 : k; refresh(false); });
          tr.addEventListener('mouseenter', function () { hot = k; refresh(false); });
          tr.addEventListener('mouseleave', function () { if (hot === k) { hot = -1; refresh(false); } });
          return tr;
        });
        countText.textContent = pairs.length + ' pairs';
      }
      rows.forEach(function (tr, k) { tr.className = k === selected ? 'dtx-sel' : k === hot ? 'dtx-hot' : ''; });
    } else {
      panes.forEach(function (P) {
        if (data.markers && P.p.markerSide) {
          const vs = P.p.markerSide === 1 ? data.markers.src : data.markers.tgt;
          vs.forEach(function (v, k) { addBall(P, v, P.p.markerSide === 1 ? 'src' : 'tgt', data.markers.label[k] || String(k + 1), false); });
        }
        if (keypoints && P.p.kind === 'sequence')
          keypoints.vertex.forEach(function (v, k) { addBall(P, v, 'key', 'key ' + (k + 1) + (keypoints.label[k] ? ' ' + keypoints.label[k] : ''), false); });
      });
    }
    dirty = true;
  }
  let countText = null;
  if (pick) {
    side.id = 'dtx-side';
    el('h3', side, 'Marker pairs');
    el('div', side, 'Click a point on the source (left), then its partner on the target (right). ' +
       'Select a row to move that pair: the next click on either mesh moves its end there. ' +
       'Drag to orbit, shift-drag or right-drag to pan, wheel to zoom.');
    labelInput = control(side, 'label of the next pair', 'input', 'text');
    const row = el('div', side);
    const bDel = el('button', row, 'Delete selected');
    const bUndo = el('button', row, 'Undo');
    const bNone = el('button', row, 'Deselect');
    const bCsv = el('button', row, 'Download CSV');
    // Symmetry helper: the selected (else the last) pair mirrored across the
    // plane through each mesh's box centre, normal to the chosen axis.
    const mrow = el('div', side);
    const bMirror = el('button', mrow, 'Add mirrored pair');
    const axis = control(mrow, ' across', 'select');
    ['x', 'y', 'z'].forEach(function (a) { const o = el('option', axis, a); o.value = a; });
    status = el('div', side, '', 'dtx-status');
    countText = el('div', side, '');
    const table = el('table', side);
    const hr = el('tr', el('thead', table));
    ['#', 'source', 'target', 'label'].forEach(function (h) { el('th', hr, h); });
    listBody = el('tbody', table);
    if (keypoints) {
      el('h3', side, 'Key points of the source (' + keypoints.vertex.length + ')');
      el('div', side, 'Yellow balls: the key points dtx keypoints chose; each becomes the source of the next pair, so only its partner on the target needs a click.');
    }
    bDel.addEventListener('click', function () {
      if (selected < 0) return;
      snapshot(); pairs.splice(selected, 1); selected = -1; say('deleted'); refresh();
    });
    bUndo.addEventListener('click', function () {
      if (!undo.length) return;
      pairs = JSON.parse(undo.pop()); selected = -1; say('undone'); refresh();
    });
    bMirror.addEventListener('click', function () {
      const k = selected >= 0 ? selected : pairs.length - 1;
      if (k < 0) return;
      const a = { x: 0, y: 1, z: 2 }[axis.value], p = pairs[k];
      const s = mirrorVertex(panes[0], p.s, a), t = mirrorVertex(panes[1], p.t, a);
      const swap = { left: 'right', right: 'left', Left: 'Right', Right: 'Left', LEFT: 'RIGHT', RIGHT: 'LEFT' };
      snapshot();
      pairs.push({ s: s, t: t, label: String(p.label).replace(/left|right/gi, function (w) { return swap[w] || w; }) });
      selected = -1;
      say('pair ' + pairs.length + ': mirror of pair ' + (k + 1) + ', ' + s + ' -> ' + t);
      refresh();
    });
    bNone.addEventListener('click', function () { selected = -1; pending = { s: null, t: null }; refresh(); });
    bCsv.addEventListener('click', function () {
      const a = document.createElement('a');
      a.href = URL.createObjectURL(new Blob([csv()], { type: 'text/csv' }));
      a.download = 'markers.csv';
      document.body.appendChild(a); a.click(); a.remove();
    });
    window.addEventListener('keydown', function (e) {
      if (e.target === labelInput) return;
      if ((e.ctrlKey || e.metaKey) && e.key === 'z') bUndo.click();
      else if (e.key === 'Delete' || e.key === 'Backspace') bDel.click();
      else if (e.key === 'Escape') bNone.click();
    });
    if (data.markers) {
      data.markers.src.forEach(function (s, k) { pairs.push({ s: s, t: data.markers.tgt[k], label: data.markers.label[k] }); });
      say('loaded ' + pairs.length + ' pairs from ' + data.markers.name);
    }
    const k = nextKeypoint();
    if (k !== null) pending.s = keypoints.vertex[k];
  }

  // ------------------------------------------------------------ start
  resize();
  resetView();
  if (nframes > 0) setFrame(0);
  refresh();
  requestAnimationFrame(tick);

  // A read-only hook for tests and scripts.
  function project(i, v) {
    const P = panes[i], w = new THREE.Vector3(P.pos[3 * v], P.pos[3 * v + 1], P.pos[3 * v + 2]).add(P.mesh.position);
    const r = paneRect(i), b = view.getBoundingClientRect();
    camera.aspect = r.w / r.h; camera.updateProjectionMatrix();
    w.project(camera);
    return { x: b.left + r.x + (w.x + 1) / 2 * r.w, y: b.top + r.y + (1 - w.y) / 2 * r.h, z: w.z };
  }
  // Turns the shared camera to look at vertex v of pane i from close by,
  // from the first direction in which nothing hides it (its normal, the
  // opposite, then the axes and diagonals): what a user does by orbiting and
  // zooming before clicking a spot.  Returns whether v is in plain sight.
  function aim(i, v, distance) {
    const P = panes[i];
    P.geom.computeVertexNormals();
    const nrm = P.geom.attributes.normal;
    const n = new THREE.Vector3(nrm.getX(v), nrm.getY(v), nrm.getZ(v)).normalize();
    const dirs = [n, n.clone().negate()];
    for (let x = -1; x <= 1; x++) for (let y = -1; y <= 1; y++) for (let z = -1; z <= 1; z++)
      if (x || y || z) dirs.push(new THREE.Vector3(x, y, z).normalize());
    const target = new THREE.Vector3(P.pos[3 * v], P.pos[3 * v + 1], P.pos[3 * v + 2]).add(P.mesh.position);
    const ray = new THREE.Raycaster();
    orbit.dist = distance || radius * 0.05;
    for (let k = 0; k <= dirs.length; k++) {
      const d = dirs[k === dirs.length ? 0 : k];
      if (!(d.lengthSq() > 0)) continue;
      orbit.target.copy(target);
      orbit.phi = Math.acos(Math.max(-1, Math.min(1, d.y)));
      orbit.theta = Math.atan2(d.x, d.z);
      placeCamera();
      if (k === dirs.length) break;
      // The same ray a click at the pane's centre casts.
      camera.aspect = paneRect(i).w / paneRect(i).h;
      camera.updateProjectionMatrix();
      ray.setFromCamera(new THREE.Vector2(0, 0), camera);
      const len = target.distanceTo(camera.position);
      const hit = ray.intersectObject(P.mesh, false)[0];
      if (hit && Math.abs(hit.distance - len) <= len * 1e-4 &&
          [hit.face.a, hit.face.b, hit.face.c].indexOf(v) >= 0) { render(); return true; }
    }
    render();
    return false;
  }
  window.dtxView = Object.freeze({
    panes: panes.length,
    nframes: nframes,
    setFrame: function (k) { setFrame(k); render(); },
    frame: function () { return frame; },
    positions: function (i) { return Array.from(panes[i].pos); },
    project: project,
    aim: aim,
    firstFrameMs: function () { return firstFrameMs; },
    pairs: function () { return JSON.parse(JSON.stringify(pairs)); },
    pending: function () { return Object.assign({}, pending); },
    csv: csv,
    lastClick: function () { return lastClick && Object.assign({}, lastClick); },
  });
})().catch(function (e) { console.error('dtx view: ' + (e && e.stack || e)); });
