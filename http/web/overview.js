// candp2 live front panel: the overview of every gateway (one tile each: DP address, name, LEDs,
// DP state, fault, frames/s) and every generic DP slave (slave.js), the routing between the
// overview and one gateway's panel (#gw=17, panel.js) or one slave's (#slave=8, slave.js) and the
// stream (/api/v1/events). The stream sends everything on connect and then only what changed
// (docs/daemon.md "Server-Sent Events"): this file keeps the merged state. The page renders its
// view from one event fetched before its load event (`?once`), so that it is complete when it
// opens and in a DOM dump; the stream goes on from there.
// A configuration with one gateway and no generic slaves (the demo) opens on its panel. Below, the
// PROFIBUS line's live list and bus cycle, when there is a line (from the stream's header).
'use strict';

// ---- state merged from the stream ----------------------------------------------------------------
const tiles = new Map();   // dp_address -> {data, refs} (gateways and generic slaves)
let open = null;           // the panel shown: {kind, addr, head, rows, panel, bus, drives}
let source = null;         // the EventSource
let single = false;        // one gateway only: no overview to go back to
// Frames/s of every gateway as its tile showed them, one point a second (the last minute), so
// that a panel opens with a chart of what the page already saw.
const fpsSeen = new Map();  // dp_address -> {rx: [], tx: [], t, now: {rx, tx}}
function noteFps(t) {
  let h = fpsSeen.get(t.dp_address);
  if (!h) { h = { rx: [], tx: [], t: -Infinity, now: t.fps }; fpsSeen.set(t.dp_address, h); }
  h.now = t.fps;
  const now = performance.now();
  if (now - h.t < 1000) return;
  h.t = now;
  h.rx.push(t.fps.rx); h.tx.push(t.fps.tx);
  if (h.rx.length > 60) { h.rx.shift(); h.tx.shift(); }
}
// The tile's frames/s of a gateway as text ("rx, tx"), or "0, 0" before its first second.
function tileFps(addr) {
  const h = fpsSeen.get(addr);
  return h ? h.now.rx + ', ' + h.now.tx : '0, 0';
}

// The panel the address bar asks for: {kind: 'gw' | 'slave', addr}, or null (the overview).
function wanted() {
  const m = /^#(gw|slave)=(\d+)$/.exec(location.hash);
  return m ? { kind: m[1], addr: Number(m[2]) } : null;
}

// ---- tiles ---------------------------------------------------------------------------------------
const TILE_LEDS = [['P', 'green'], ['D', 'green'], ['E', 'red'], ['C', 'green']];
function makeTile(t) {
  const x = { leds: {} };
  const leds = el('div', { class: 'tleds' });
  for (const [name, color] of TILE_LEDS) {
    const led = el('span', { class: 'led ' + color, title: 'LED ' + name, 'data-code': '0' });
    x.leds[name] = { led, code: 0, color };
    leds.append(el('span', { class: 'tled' }, led, el('span', { class: 'n', text: name })));
  }
  x.addr = el('span', { class: 'taddr' });
  x.name = el('span', { class: 'tname' });
  x.state = el('span', { class: 'tstate' });
  x.fault = el('div', { class: 'tfault' });
  x.fps = el('div', { class: 'tfps mono' });
  x.root = el('a', { class: 'tile', id: 'tile-' + t.dp_address, href: '#gw=' + t.dp_address },
    el('div', { class: 'thead' }, x.addr, x.name), leds, x.state, x.fault, x.fps);
  document.getElementById('tiles').append(x.root);
  return x;
}
function updateTile(x, t) {
  setText(x.addr, String(t.dp_address).padStart(3, '0'));
  setText(x.name, t.name + ' · ' + t.bus);
  for (const [name] of TILE_LEDS) {
    const L = x.leds[name];
    L.code = t.leds[name];
    L.led.dataset.code = String(L.code);
  }
  setText(x.state, t.dp_state);
  setClass(x.state, 'tstate state-' + t.dp_state);
  setText(x.fault, t.fault || '');
  setClass(x.root, 'tile' + (t.fault ? ' faulty' : ''));
  setText(x.fps, 'rx ' + t.fps.rx + ' · tx ' + t.fps.tx + ' frames/s');
  noteFps(t);
}
function renderTiles(list, make, update) {
  for (const t of list) {
    let x = tiles.get(t.dp_address);
    if (!x) { x = make(t); tiles.set(t.dp_address, x); }
    update(x, t);
  }
}

// ---- the open panel --------------------------------------------------------------------------------
function closePanel() {
  document.getElementById('panel').replaceChildren();
  open = null;
}
function renderPanel(s) {
  if (open && open.kind === 'slave') {
    if (s.open_slave !== open.addr || !s.slave) return;
    if (!open.panel) open.panel = makeSlavePanel(s.slave);
    updateSlavePanel(open.panel, s.slave);
    return;
  }
  if (!open || s.open !== open.addr) return;
  if (s.panel) open.head = s.panel;
  if (s.full && open.bus) { open.bus.lastSeq = 0; open.bus.frames = []; }  // a new stream: new numbering
  for (const row of s.slots || []) open.rows[row.slot] = row;
  if (!open.head) return;
  if (!open.panel) open.panel = makePanel(open.head);
  updatePanel(open.panel, open.head, open.rows, s.time_ms);
  for (const b of s.buses || []) {
    if (!open.bus) open.bus = makeBus(b);
    updateBus(open.bus, b);
  }
  if (open.bus && s.trace) addTrace(open.bus, s.trace);
  for (const d of s.drives || []) {
    let x = open.drives.get(d.name);
    if (!x) { x = { view: makeDrive(d) }; open.drives.set(d.name, x); }
    x.data = d;
  }
  // One point per event for every drive, changed or not: the plots run at the stream's pace.
  for (const x of open.drives.values()) updateDrive(x.view, x.data);
}

// ---- view and stream ---------------------------------------------------------------------------
function show() {
  const want = wanted();
  const panelView = want !== null;
  document.getElementById('overview').hidden = panelView;
  document.getElementById('back').hidden = !panelView || single;
  setText(document.getElementById('where'),
    panelView ? (want.kind === 'gw' ? 'gateway ' : 'slave ') + want.addr : 'overview');
  if (!open || !want || open.addr !== want.addr || open.kind !== want.kind) closePanel();
  if (panelView && !open)
    open = { kind: want.kind, addr: want.addr, head: null, rows: [], panel: null, bus: null, drives: new Map() };
  connect(want);
}

function renderHeader(s) {
  const c = s.cycle || {};
  const lat = c.lateness_us;
  let text = c.period_ms + ' ms';
  if (c.missed !== undefined) text += ' · missed ' + c.missed;
  if (lat) text += ' · late p50 ' + us(lat.p50) + ', p99 ' + us(lat.p99);
  // The line in time (docs/profibus.md): the measured bus cycle, last and longest (a line in
  // profibus.role "master" has none).
  // The steady line's figures (docs/daemon.md "Statistics of the steady line"): none until the
  // first rotation that parameterized no station.
  const bc = s.line && s.line.bus_cycle_us;
  if (bc && bc.cycles) text += ' · bus cycle ' + us(bc.last) + ' (max ' + us(bc.max) + ' at ' +
    s.line.baud / 1000 + ' kbit/s)';
  else if (bc) text += ' · bus cycle – (stations being parameterized, ' + s.line.baud / 1000 +
    ' kbit/s)';
  const cyc = document.getElementById('cycle');
  setText(cyc, text);
  setClass(cyc, c.missed ? 'warn' : '');
  if (s.modbus) setText(document.getElementById('modbus'), s.modbus.requests + ' req · ' + s.modbus.clients + ' client(s)');
  // Host stalls (docs/daemon.md "Host stalls"): the host, not the simulated world, stopped; shown
  // once there was one, so that a late reply or a gap in a log has its explanation in sight.
  const hs = s.host_stalls;
  if (hs && hs.count > 0) {
    setText(document.getElementById('stalls'), hs.count + ' · ' + us(hs.total_ms * 1000) + ' (longest ' +
      us(hs.longest_ms * 1000) + ')');
    document.getElementById('stalls-wrap').hidden = false;
  }
  if (s.gateway_count !== undefined) {
    const count = document.getElementById('count');
    setText(count, s.gateway_count);
    // A line of generic slaves alone (docs/slaves.md): no gateways to count.
    count.parentElement.hidden = s.gateway_count === 0 && !!s.slave_count;
  }
  if (s.slave_count !== undefined) {
    setText(document.getElementById('scount'), s.slave_count);
    document.getElementById('slaves').hidden = false;
  }
}

function render(s) {
  renderHeader(s);
  renderLine(s.line);
  renderTiles(s.gateways || [], makeTile, updateTile);
  renderTiles(s.slaves || [], makeSlaveTile, updateSlaveTile);
  if (s.full && wanted() === null && s.gateway_count === 1 && s.gateways.length === 1 &&
      !s.slave_count) {
    // The demo: one gateway, nothing to choose from.
    single = true;
    location.replace('#gw=' + s.gateways[0].dp_address);
    return;
  }
  renderPanel(s);
  document.body.dataset.snapshot = String(s.time_ms);
  document.body.dataset.tiles = String(tiles.size);
  // When the whole overview was first painted (ms since the page's navigation started).
  if (!document.body.dataset.drawn && s.gateway_count !== undefined &&
      tiles.size >= s.gateway_count + (s.slave_count || 0))
    requestAnimationFrame(() => { document.body.dataset.drawn = String(Math.round(performance.now())); });
  markRendered(s);
}

// The first time the view the page opened on is complete (every tile; the open panel with its
// slot rows or modules; the line view when there is a line): `data-rendered` on the body and the
// performance mark `candp2-rendered`, ms since the page's navigation started (the browser tests
// read them).
function markRendered(s) {
  if (document.body.dataset.rendered || s.gateway_count === undefined) return;
  if (tiles.size < s.gateway_count + (s.slave_count || 0)) return;
  if (wanted() !== null && !(open && open.panel)) return;
  if (s.line && !line.view) return;
  performance.mark('candp2-rendered');
  document.body.dataset.rendered = String(Math.round(performance.now()));
}

function streamUrl(want, once) {
  const q = (want === null ? [] : [want.kind + '=' + want.addr]).concat(once ? ['once'] : []);
  return '/api/v1/events' + (q.length ? '?' + q.join('&') : '');
}

function connect(want) {
  if (source) source.close();
  const conn = document.getElementById('conn');
  source = new EventSource(streamUrl(want, false));
  source.addEventListener('status', ev => {
    setText(conn, 'live'); setClass(conn, 'conn on');
    render(JSON.parse(ev.data));
    animateLeds();
  });
  source.onerror = () => { setText(conn, 'reconnecting…'); setClass(conn, 'conn off'); };
}

// The stream's first event for `want`, fetched synchronously (the load event waits for it, so a
// DOM dump after the load has the data), or null. One round of the live view: a few ms at one
// gateway, tens at 122 × 48.
function firstEvent(want) {
  const x = new XMLHttpRequest();
  try {
    x.open('GET', streamUrl(want, true), false);
    x.send();
  } catch (e) {
    return null;  // the daemon away: the stream will say so
  }
  const m = x.status === 200 && /^data: (.*)$/m.exec(x.responseText);
  return m ? JSON.parse(m[1]) : null;
}

// Opening the page: the view from the first event, then the stream.
function boot() {
  let s = firstEvent(wanted());
  if (s && wanted() === null && s.gateway_count === 1 && s.gateways.length === 1 && !s.slave_count) {
    single = true;  // the demo: its panel at once
    history.replaceState(null, '', '#gw=' + s.gateways[0].dp_address);
    s = firstEvent(wanted());
  }
  show();
  if (s) {
    render(s);
    animateLeds();
  }
}

function animateLeds() {
  const t = performance.now();
  const all = [...tiles.values()].filter(x => x.leds).map(x => x.leds);
  if (open && open.panel && open.panel.leds) all.push(open.panel.leds);
  for (const leds of all)
    for (const L of Object.values(leds)) {
      const cls = 'led ' + L.color + (ledLit(L.code, t) ? ' on' : '');
      if (L.led.className !== cls) L.led.className = cls;
    }
}
setInterval(animateLeds, 40);

// ---- the PROFIBUS line (docs/profibus.md "Line statistics"): live list and bus cycle ------------
// Shown only when the stream's header has "line" (a line in time, profibus.role "master"; the
// same object as in GET /api/v1/status, and `counters`: the station counters' names in the
// table's order). One tile per station: its address, its live state as a colour, its counters in
// that order under the document's names (none is listed here); the bus cycle's last, min, mean
// and max, a point a second over the last two minutes. The axis follows the running cycle (last,
// min, mean): the max since the start (the start-up rotation) is drawn clipped to it.
const LINE_POINT_MS = 1000, LINE_POINTS = 120;
const LINE_SERIES = [['last', '#5fb3ff'], ['min', '#35e06b'], ['mean', '#d8dee6'], ['max', '#ffb62e']];
const line = { view: null, tiles: new Map(), cycle: {}, pointAt: -Infinity };
for (const [k] of LINE_SERIES) line.cycle[k] = [];

function lineView() {
  if (line.view) return line.view;
  const v = {};
  v.info = el('span', { class: 'hw' });
  v.tiles = el('div', { class: 'tiles ltiles' });
  v.canvas = el('canvas');
  v.plot = el('div', { class: 'card lplot' }, el('h3', { text: 'Bus cycle, last two minutes' }),
    v.canvas, el('div', { class: 'legend' },
      ...LINE_SERIES.map(([k, color]) => el('span', { style: 'color:' + color, text: '— ' + k + ' ' })),
      'a point a second'));
  v.root = document.getElementById('line');
  v.root.append(el('div', { class: 'card' }, el('div', { class: 'lhead' },
    el('h2', { text: 'PROFIBUS line' }), v.info), v.tiles), v.plot);
  line.view = v;
  return v;
}

function lineTile(v, addr) {
  let x = line.tiles.get(addr);
  if (x) return x;
  x = { addr: el('span', { class: 'taddr' }), live: el('span', { class: 'tname' }),
        counters: el('dl', { class: 'kv lcounters' }), fault: el('div', { class: 'tfault' }) };
  x.root = el('div', { class: 'tile ltile', id: 'line-' + addr },
    el('div', { class: 'thead' }, x.addr, x.live), x.counters, x.fault);
  const after = [...line.tiles.keys()].filter(a => a > addr).sort((a, b) => a - b)[0];
  v.tiles.insertBefore(x.root, after === undefined ? null : line.tiles.get(after).root);
  line.tiles.set(addr, x);
  return x;
}

function renderLine(l) {
  if (!l) {  // no line (or none any more)
    document.getElementById('line').hidden = true;
    return;
  }
  const v = lineView();
  v.root.hidden = false;
  const live = l.live_list || {};
  const n = k => (live[k] || []).length;
  setText(v.info, l.baud / 1000 + ' kbit/s · ok ' + n('ok') + ' · missing ' + n('missing') +
    ' · phantom ' + n('phantom') + (l.illegals_unattributed ? ' · illegals unattributed ' +
    l.illegals_unattributed : '') + (l.noise_remaining_ms ? ' · noise ' + l.noise_remaining_ms + ' ms' : ''));
  // The stations (or, without them, the live list's addresses).
  const stations = l.stations || Object.entries(live).flatMap(
    ([state, addrs]) => addrs.map(address => ({ address, live: state })));
  const seen = new Set();
  for (const st of stations) {
    const x = lineTile(v, st.address);
    seen.add(st.address);
    setText(x.addr, String(st.address).padStart(3, '0'));
    setText(x.live, st.live);
    setClass(x.root, 'tile ltile live-' + st.live);
    const names = l.counters || Object.keys(st).filter(k => k !== 'address' && typeof st[k] === 'number');
    kvSet(x.counters, names.map(k => [k, st[k]]));
    const f = st.fault;
    setText(x.fault, f ? f.kind + (f.remaining_ms ? ' ' + f.remaining_ms + ' ms' : ' ×' + f.remaining) +
      (f.every > 1 ? ', every ' + f.every : '') : '');
  }
  for (const [a, x] of line.tiles) if (!seen.has(a)) { x.root.remove(); line.tiles.delete(a); }
  v.tiles.dataset.count = String(line.tiles.size);
  // The bus cycle (a line in time only).
  const c = l.bus_cycle_us;
  v.plot.hidden = !c;
  if (!c) return;
  const now = performance.now();
  if (now - line.pointAt < LINE_POINT_MS) return;
  line.pointAt = now;
  for (const [k] of LINE_SERIES) {
    line.cycle[k].push(c[k]);
    if (line.cycle[k].length > LINE_POINTS) line.cycle[k].shift();
  }
  v.canvas.dataset.points = String(line.cycle.last.length);
  plot(v.canvas, LINE_SERIES.map(([k, color]) => ({ data: line.cycle[k], color, scale: k !== 'max' })),
    { points: LINE_POINTS, label: '120 s', fmt: us, left: 52 });
}

window.addEventListener('hashchange', show);
boot();
