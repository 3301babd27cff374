// rumi's web view (docs/view.md): the top view of the map, the occupancy
// grid under it, the tracking timeline and the daemon's panel. Loads
// /api/map, /api/state and /api/grid once, then follows /api/events (SSE):
// map deltas, poses, status. Nothing is fetched from anywhere else.
'use strict';

const token = new URLSearchParams(location.search).get('token');
function api(path) {
  return token ? path + (path.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(token) : path;
}
const $ = (id) => document.getElementById(id);
window.addEventListener('error', (e) => { $('errors').textContent += (e.message || e) + '\n'; });
window.addEventListener('unhandledrejection', (e) => { $('errors').textContent += 'unhandled: ' + e.reason + '\n'; });

// The map as the page holds it; map deltas apply to it (TopViewDelta).
const view = { seq: 0, frame: 'map', cell_m: 1, cells: new Set(), kfs: new Map(), submaps: new Map(), links: [], counts: {} };
const live = { trail: [], timeline: [], timelineSeq: 0, windows: [], events: [], poseT: 0, status: {}, managerStats: {}, grid: null, gridImage: null };
const EVENTS = 200;
const TRAIL = 600;
const PALETTE = ['#1565c0', '#ef6c00', '#6a1b9a', '#00897b', '#c2185b', '#5d4037', '#7cb342', '#3949ab'];
const STATE_COLOUR = { tracking: '#43a047', coarse: '#fbc02d', lost: '#e53935', initializing: '#9e9e9e' };
const componentColour = (c) => (c < 0 ? '#999' : PALETTE[c % PALETTE.length]);

// False when the delta is not from the map we hold: fetch the whole map.
function applyMap(d) {
  if (!d.reset && d.base !== view.seq) return false;
  if (d.reset) { view.cells.clear(); view.kfs.clear(); view.submaps.clear(); }
  for (let i = 0; i + 1 < d.cells_add.length; i += 2) view.cells.add(d.cells_add[i] + ',' + d.cells_add[i + 1]);
  for (let i = 0; i + 1 < d.cells_del.length; i += 2) view.cells.delete(d.cells_del[i] + ',' + d.cells_del[i + 1]);
  for (const [k, x, y, yaw, c] of d.kf_set) view.kfs.set(k, { x: x / 1000, y: y / 1000, yaw: yaw * Math.PI / 180, c });
  for (const k of d.kf_del) view.kfs.delete(k);
  for (const [k, kind, c, kfs, pts, first, last] of d.sm_set) view.submaps.set(k, { kind, c, kfs, pts, first, last });
  for (const k of d.sm_del) view.submaps.delete(k);
  view.links = d.links;
  view.seq = d.seq; view.frame = d.frame; view.cell_m = d.cell_m; view.counts = d.counts;
  return true;
}

async function getJson(path) {
  const r = await fetch(api(path));
  if (!r.ok) throw new Error(path + ': ' + r.status + ' ' + (await r.text()));
  return r.json();
}

async function loadMap() { applyMap(await getJson('/api/map')); }

// A timeline delta (TimelineDelta: keep, add) applies to the timeline of its
// base only; false: fetch the whole timeline.
function applyTimeline(d) {
  if (d.base !== live.timelineSeq) return false;
  live.timeline.length = Math.min(live.timeline.length, d.keep);
  live.timeline.push(...d.add);
  live.timelineSeq = d.seq;
  return true;
}

async function loadTimeline() {
  const t = await getJson('/api/timeline');
  live.timeline = t.timeline; live.timelineSeq = t.seq;
}

// map_server's PGM (254 free, 0 occupied, 205 unknown) as an image, drawn as it is.
async function loadGrid() {
  live.grid = await getJson('/api/grid');
  live.gridImage = null;
  if (!live.grid.ok) return;
  const r = await fetch(api('/api/grid.pgm'));
  if (!r.ok) return;
  const bytes = new Uint8Array(await r.arrayBuffer());
  let at = 0;
  const word = () => {
    while (at < bytes.length && /\s/.test(String.fromCharCode(bytes[at]))) at++;
    let s = '';
    while (at < bytes.length && !/\s/.test(String.fromCharCode(bytes[at]))) s += String.fromCharCode(bytes[at++]);
    return s;
  };
  if (word() !== 'P5') throw new Error('grid.pgm: not a binary PGM');
  const w = +word(), h = +word();
  word();
  at++;  // the one whitespace before the pixels
  const canvas = document.createElement('canvas');
  canvas.width = w; canvas.height = h;
  const ctx = canvas.getContext('2d');
  const img = ctx.createImageData(w, h);
  for (let i = 0; i < w * h; i++) {
    const v = bytes[at + i];
    img.data.set([v, v, v, v === 205 ? 90 : 255], 4 * i);
  }
  ctx.putImageData(img, 0, 0);
  live.gridImage = canvas;
}

function setState(state) {
  live.status = state.status || {};
  live.managerStats = state.manager_stats || {};
  live.timeline = state.timeline || [];
  live.timelineSeq = state.timeline_seq || 0;
  live.windows = state.windows || [];
  live.poseT = state.pose_t || 0;
  live.events = state.events || [];
  live.trail = (state.trail || []).map(([t, x, y, yaw]) => ({ t, x, y, yaw }));
}

// ---- the top view ----
function bounds() {
  const b = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
  const add = (x, y) => { b.x0 = Math.min(b.x0, x); b.y0 = Math.min(b.y0, y); b.x1 = Math.max(b.x1, x); b.y1 = Math.max(b.y1, y); };
  // The points' 1st to 99th percentile: a few stray far points must not
  // shrink the map to a corner (the keyframes and the trail always fit).
  const xs = [], ys = [];
  for (const key of view.cells) { const [i, j] = key.split(',').map(Number); xs.push(i * view.cell_m); ys.push(j * view.cell_m); }
  if (xs.length) {
    xs.sort((a, b) => a - b); ys.sort((a, b) => a - b);
    const at = (v, q) => v[Math.min(v.length - 1, Math.floor(q * v.length))];
    add(at(xs, 0.01), at(ys, 0.01)); add(at(xs, 0.99) + view.cell_m, at(ys, 0.99) + view.cell_m);
  }
  for (const k of view.kfs.values()) add(k.x, k.y);
  for (const p of live.trail) add(p.x, p.y);
  if (!isFinite(b.x0)) return { x0: -1, y0: -1, x1: 1, y1: 1 };
  const pad = 0.05 * Math.max(b.x1 - b.x0, b.y1 - b.y0, 0.5);
  return { x0: b.x0 - pad, y0: b.y0 - pad, x1: b.x1 + pad, y1: b.y1 + pad };
}

function drawTop() {
  const canvas = $('top');
  const ctx = canvas.getContext('2d');
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  const b = bounds();
  const s = Math.min(canvas.width / (b.x1 - b.x0), canvas.height / (b.y1 - b.y0));
  const X = (x) => (x - b.x0) * s, Y = (y) => canvas.height - (y - b.y0) * s;
  let gridDrawn = 'no';
  if ($('grid-toggle').checked && live.gridImage && live.grid.frame === view.frame && view.frame === 'grid') {
    const g = live.grid;
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(live.gridImage, X(g.origin[0]), Y(g.origin[1] + g.height * g.resolution),
                  g.width * g.resolution * s, g.height * g.resolution * s);
    gridDrawn = 'yes';
  }
  ctx.fillStyle = '#37474f';
  const px = Math.max(1, view.cell_m * s);
  for (const key of view.cells) {
    const [i, j] = key.split(',').map(Number);
    ctx.fillRect(X(i * view.cell_m), Y((j + 1) * view.cell_m), px, px);
  }
  // Joins: a back submap and the front submaps it was joined to, centre to centre.
  const centres = new Map();
  for (const [key, k] of view.kfs) {
    const sm = key.slice(0, key.lastIndexOf(':'));
    const c = centres.get(sm) || { x: 0, y: 0, n: 0 };
    c.x += k.x; c.y += k.y; c.n++;
    centres.set(sm, c);
  }
  ctx.strokeStyle = '#ff6f00'; ctx.lineWidth = 2; ctx.setLineDash([6, 4]);
  for (const [a, bk] of view.links) {
    const ca = centres.get(a), cb = centres.get(bk);
    if (!ca || !cb) continue;
    ctx.beginPath(); ctx.moveTo(X(ca.x / ca.n), Y(ca.y / ca.n)); ctx.lineTo(X(cb.x / cb.n), Y(cb.y / cb.n)); ctx.stroke();
  }
  // The manager's merges (thin) and closed loops (purple), as it announced them.
  for (const [kind, a, bk] of live.events) {
    if (kind !== 'merged' && kind !== 'loop') continue;
    const ca = centres.get(a), cb = centres.get(bk);
    if (!ca || !cb) continue;
    ctx.strokeStyle = kind === 'loop' ? '#8e24aa' : '#ff6f00';
    ctx.lineWidth = kind === 'loop' ? 2 : 1;
    ctx.setLineDash(kind === 'loop' ? [2, 3] : []);
    ctx.beginPath(); ctx.moveTo(X(ca.x / ca.n), Y(ca.y / ca.n)); ctx.lineTo(X(cb.x / cb.n), Y(cb.y / cb.n)); ctx.stroke();
  }
  ctx.setLineDash([]);
  let kfs = 0;
  for (const [key, k] of view.kfs) {
    const sm = view.submaps.get(key.slice(0, key.lastIndexOf(':')));
    const back = sm && sm.kind === 'back';
    ctx.fillStyle = componentColour(k.c);
    ctx.strokeStyle = componentColour(k.c);
    const x = X(k.x), y = Y(k.y);
    if (back) {
      ctx.strokeRect(x - 3, y - 3, 6, 6);
    } else {
      ctx.beginPath();
      ctx.moveTo(x + 6 * Math.cos(k.yaw), y - 6 * Math.sin(k.yaw));
      ctx.lineTo(x + 3 * Math.cos(k.yaw + 2.5), y - 3 * Math.sin(k.yaw + 2.5));
      ctx.lineTo(x + 3 * Math.cos(k.yaw - 2.5), y - 3 * Math.sin(k.yaw - 2.5));
      ctx.fill();
    }
    kfs++;
  }
  if (live.trail.length) {
    ctx.strokeStyle = '#d50000'; ctx.lineWidth = 2; ctx.beginPath();
    live.trail.forEach((p, i) => (i ? ctx.lineTo(X(p.x), Y(p.y)) : ctx.moveTo(X(p.x), Y(p.y))));
    ctx.stroke();
    const p = live.trail[live.trail.length - 1];
    ctx.fillStyle = '#d50000'; ctx.beginPath(); ctx.arc(X(p.x), Y(p.y), 6, 0, 2 * Math.PI); ctx.fill();
    ctx.beginPath(); ctx.moveTo(X(p.x), Y(p.y)); ctx.lineTo(X(p.x) + 16 * Math.cos(p.yaw), Y(p.y) - 16 * Math.sin(p.yaw)); ctx.stroke();
  }
  $('drawn-cells').textContent = view.cells.size;
  $('drawn-keyframes').textContent = kfs;
  $('drawn-trail').textContent = live.trail.length;
  $('drawn-grid').textContent = gridDrawn;
  $('frame').textContent = view.frame;
  $('cell').textContent = view.cell_m.toPrecision(3);
  const comps = new Map();
  for (const sm of view.submaps.values()) {
    const c = comps.get(sm.c) || { front: 0, back: 0 };
    c[sm.kind === 'back' ? 'back' : 'front']++;
    comps.set(sm.c, c);
  }
  const legend = $('legend');
  legend.textContent = '';
  for (const [c, n] of [...comps].sort((a, b) => a[0] - b[0])) {
    const span = document.createElement('span');
    span.className = 'component';
    const sw = document.createElement('span');
    sw.className = 'sw';
    sw.style.background = componentColour(c);
    span.append(sw, (c === 0 ? 'main map' : 'component ' + c + ' (not joined)') + ': ' + n.front + ' front, ' + n.back + ' back');
    legend.append(span);
  }
  const note = document.createElement('span');
  note.textContent = '▲ front keyframe · □ back keyframe · dashed: joins · thin: merges · purple: loops · red: live pose';
  legend.append(note);
}

// The window the back builds now (status.json's back.building: window,
// stage, elapsed_s, frames), or null.
function building() {
  const b = ((live.status || {}).back || {}).building;
  return b && b.window !== undefined ? b : null;
}
const buildingText = (b) =>
  'window ' + b.window + ': ' + b.stage + ', ' + (b.elapsed_s || 0).toFixed(0) + ' s' + (b.frames ? ' (' + b.frames + ' frames)' : '');

// ---- the timeline: tracking state per frame, back and front submaps ----
function drawTimeline() {
  const canvas = $('timeline');
  const ctx = canvas.getContext('2d');
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  let t0 = Infinity, t1 = -Infinity;
  for (const [t] of live.timeline) { t0 = Math.min(t0, t); t1 = Math.max(t1, t); }
  for (const sm of view.submaps.values()) if (sm.kfs) { t0 = Math.min(t0, sm.first); t1 = Math.max(t1, sm.last); }
  if (live.poseT && isFinite(t0)) t1 = Math.max(t1, live.poseT);  // the state goes on to the last pose
  for (const [, first, last] of live.windows) { t0 = Math.min(t0, first); t1 = Math.max(t1, last); }
  $('timeline-count').textContent = live.timeline.length;
  $('windows-count').textContent = live.windows.length;
  if (!isFinite(t0) || t1 <= t0) return;
  const X = (t) => 44 + (t - t0) / (t1 - t0) * (canvas.width - 54);
  ctx.font = '11px sans-serif'; ctx.fillStyle = '#555';
  ctx.fillText('state', 2, 20); ctx.fillText('window', 2, 52); ctx.fillText('back', 2, 84); ctx.fillText('front', 2, 116);
  // Each window sent to the back over the frames it holds, and its samples
  // by set; the one the back builds now in orange, with its stage.
  const now = building();
  for (const [id, first, last, s1, s2, s3] of live.windows) {
    const built = now && now.window === id;
    ctx.fillStyle = built ? '#f57c00' : '#00897b';
    ctx.fillRect(X(first), 40, Math.max(2, X(last) - X(first)), 18);
    ctx.fillStyle = '#fff';
    ctx.fillText('#' + id + ' S1 ' + s1 + ' S2 ' + s2 + ' S3 ' + s3 +
                 (built ? ' · ' + now.stage + ' ' + (now.elapsed_s || 0).toFixed(0) + ' s' : ''), X(first) + 3, 53);
  }
  for (let i = 0; i < live.timeline.length; i++) {
    const [t, state] = live.timeline[i];
    if (state === 'end') continue;
    const next = i + 1 < live.timeline.length ? live.timeline[i + 1][0] : t1;
    ctx.fillStyle = STATE_COLOUR[state] || '#9e9e9e';
    ctx.fillRect(X(t), 8, Math.max(1, X(next) - X(t)), 18);
  }
  const joined = new Set(view.links.map(([a]) => a));
  for (const [key, sm] of view.submaps) {
    if (!sm.kfs) continue;
    const back = sm.kind === 'back';
    ctx.fillStyle = back ? '#1e88e5' : componentColour(sm.c);
    const y = back ? 72 : 104;
    ctx.fillRect(X(sm.first), y, Math.max(2, X(sm.last) - X(sm.first)), 18);
    if (back && joined.has(key)) { ctx.fillStyle = '#fff'; ctx.fillText('✓', X(sm.first) + 2, y + 13); }
  }
  ctx.fillStyle = '#555';
  ctx.fillText(t0.toFixed(1) + ' s', 44, 138);
  ctx.fillText(t1.toFixed(1) + ' s', canvas.width - 60, 138);
}

// ---- the daemon panel ----
function details(title, obj, keys) {
  if (!obj || typeof obj !== 'object') return null;
  const dl = document.createElement('dl');
  for (const k of keys || Object.keys(obj)) {
    const v = obj[k];
    if (v === undefined || v === null || typeof v === 'object') continue;
    const dt = document.createElement('dt'); dt.textContent = k;
    const dd = document.createElement('dd'); dd.textContent = typeof v === 'number' ? +v.toFixed(3) : v;
    dl.append(dt, dd);
  }
  if (!dl.children.length) return null;
  const h = document.createElement('h3'); h.textContent = title;
  const div = document.createElement('div'); div.append(h, dl);
  return div;
}

function drawDaemon() {
  const st = live.status || {};
  $('instance').textContent = st.instance || '';
  const state = st.state || (view.seq ? 'saved session' : 'waiting');
  const badge = $('state');
  badge.textContent = state;
  badge.className = 'badge ' + ({ running: 'ok', finishing: 'warn', starting: 'warn', failed: 'bad' }[state] || '');
  $('daemon-summary').textContent = st.summary || (st.updated ? 'updated ' + st.updated : 'no daemon status in this folder');
  const b = building();
  $('back-building').textContent = b ? 'the back builds ' + buildingText(b) : st.back ? 'the back builds nothing now' : '';
  const body = $('children').tBodies[0];
  body.textContent = '';
  for (const c of st.children || []) {
    const tr = body.insertRow();
    for (const v of [c.name, c.state, c.restarts, c.rss_mib ? c.rss_mib.toFixed(0) + ' MiB' : '', c.uptime_s ? c.uptime_s.toFixed(0) + ' s' : ''])
      tr.insertCell().textContent = v === undefined ? '' : v;
  }
  const box = $('daemon-details');
  box.textContent = '';
  const parts = [
    details('back', st.back),
    details('manager', st.manager),
    details('front', st.front),
    st.front && st.front.link ? details('robot link', st.front.link) : null,
    st.front && st.front.link && st.front.link.latency_ms ? details('link latency (ms)', st.front.link.latency_ms) : null,
  ];
  const saved = details('map at its last save', live.managerStats,
                        ['last_save', 'components', 'submaps_front', 'submaps_back', 'merges', 'loop_closures',
                         'points_after_culling', 'rebuilds', 'last_rebuild_seconds']);
  if (saved) {  // the merge reports and the loops: fetched when asked, not streamed
    const a = document.createElement('a');
    a.href = api('/api/manager_stats'); a.textContent = 'all of manager_stats.json'; a.id = 'manager-stats-link';
    saved.append(a);
  }
  parts.push(saved);
  const rings = {};
  for (const r of st.rings || []) rings[r.name] = (r.dropped || 0) + ' dropped';
  parts.push(details('rings', rings));
  if (st.view) parts.push(details('view', { address: st.view }));
  for (const p of parts) if (p) box.append(p);
}

function drawCounts() {
  const c = view.counts || {};
  for (const k of ['points', 'keyframes', 'submaps', 'components', 'links']) $('count-' + k).textContent = c[k] || 0;
  // The manager's own count in rumid's status.json (what `rumi status` says;
  // the events kept are the last 200 only); else its events (live); else
  // its last save's counts.
  const manager = (live.status || {}).manager || {};
  const counted = (statusKey, kind, saved) =>
    manager[statusKey] !== undefined ? manager[statusKey]
      : live.events.length ? live.events.filter(([k]) => k === kind).length : live.managerStats[saved] || 0;
  $('count-merges').textContent = counted('merges', 'merged', 'merges');
  $('count-loops').textContent = counted('loops', 'loop', 'loop_closures');
}

function drawEvents() {
  const list = $('events');
  list.textContent = '';
  const shown = live.events.filter(([kind]) => kind !== 'saved').slice(-12);
  list.start = live.events.length;
  for (const [kind, a, b, detail] of shown.reverse()) {
    const li = document.createElement('li');
    li.textContent = kind + ' ' + a + (b ? ' → ' + b : '') + (detail ? ' (' + detail + ')' : '');
    list.append(li);
  }
  if (!shown.length) list.textContent = 'none yet (they come from rumi-manager over DDS)';
}

let pending = false;
function redraw() {
  if (pending) return;
  pending = true;
  requestAnimationFrame(() => { pending = false; drawAll(); });
}
function drawAll() { drawCounts(); drawTop(); drawTimeline(); drawDaemon(); drawEvents(); }

function follow() {
  const es = new EventSource(api('/api/events'));
  es.onopen = () => { $('live').textContent = 'live'; $('live').className = 'badge ok'; };
  es.onerror = () => {  // a refused stream (the view stopping) is not asked again
    $('live').textContent = es.readyState === EventSource.CLOSED ? 'offline' : 'reconnecting';
    $('live').className = 'badge off';
  };
  es.addEventListener('map', (e) => {
    if (!applyMap(JSON.parse(e.data))) loadMap().then(redraw);
    redraw();
  });
  es.addEventListener('grid', () => loadGrid().then(redraw));
  es.addEventListener('status', (e) => { live.status = JSON.parse(e.data); redraw(); });
  es.addEventListener('manager_stats', (e) => { live.managerStats = JSON.parse(e.data); redraw(); });
  es.addEventListener('timeline', (e) => {
    if (!applyTimeline(JSON.parse(e.data))) loadTimeline().then(redraw);
    redraw();
  });
  es.addEventListener('windows', (e) => { live.windows = JSON.parse(e.data); redraw(); });
  es.addEventListener('events', (e) => {
    live.events.push(...JSON.parse(e.data));
    if (live.events.length > EVENTS) live.events.splice(0, live.events.length - EVENTS);
    redraw();
  });
  es.addEventListener('pose', (e) => {
    const p = JSON.parse(e.data);
    live.poseT = Math.max(live.poseT, p.t);
    const last = live.timeline[live.timeline.length - 1];
    if (!last || last[1] !== p.state) { live.timeline.push([p.t, p.state]); live.timelineSeq++; }  // as the hub
    if (p.x !== undefined) {
      live.trail.push(p);
      if (live.trail.length > TRAIL) live.trail.splice(0, live.trail.length - TRAIL);
    }
    redraw();
  });
}

$('grid-toggle').addEventListener('change', redraw);

(async () => {
  const [, state] = await Promise.all([loadMap(), getJson('/api/state'), loadGrid()]);
  setState(state);
  drawAll();
  $('loaded').textContent = 'yes';
  // A page opened to look at a finished session still follows: the folder
  // may be a running daemon's.
  if (new URLSearchParams(location.search).get('live') !== '0') follow();
})().catch((e) => { $('errors').textContent += String(e) + '\n'; });
