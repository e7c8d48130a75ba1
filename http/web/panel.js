// candp2 live front panel: the full panel of one gateway (front plate with LEDs, diagnosis,
// parameters, slot table, frames/s plot), its bus (load, live trace) and the drives on that bus.
// overview.js holds the overview of every gateway, the routing (#gw=17) and the stream.
// Plain JavaScript, no libraries, no build step, nothing from the network (docs/daemon.md).
'use strict';

// ---- LED codes (manual §3.3, table 3.3.1; the status block's led codes, docs/modbus.md) --------
// The manual gives the patterns (n short flashes; Morse E, W, O) and says they repeat about every
// six seconds; it gives no element lengths. Chosen (docs/daemon.md "LED timing"): short 200 ms on,
// long 600 ms on, 300 ms dark between elements, the sequence restarting every 6000 ms.
const LED_PERIOD = 6000, SHORT = 200, LONG = 600, GAP = 300;
const MORSE = { 0x45: 'E', 0x57: 'W', 0x4F: 'O' };
const MORSE_ELEMENTS = { E: [SHORT], W: [SHORT, LONG, LONG], O: [LONG, LONG, LONG] };
function ledElements(code) {
  if (code >= 2 && code <= 4) return Array(code).fill(SHORT);  // LED E: n short flashes
  if (MORSE[code]) return MORSE_ELEMENTS[MORSE[code]];
  return null;
}
function ledLit(code, tMs) {
  if (code === 0) return false;
  if (code === 1) return true;
  const els = ledElements(code);
  if (!els) return false;
  let t = tMs % LED_PERIOD;
  for (const on of els) {
    if (t < on) return true;
    t -= on + GAP;
    if (t < 0) return false;
  }
  return false;
}
function ledMeaning(name, code) {
  if (name === 'P') return code ? 'power' : 'init';
  if (name === 'D') return code === 1 ? 'data exch.' : 'no data';
  if (name === 'E') return code >= 1 && code <= 4 ? ['', 'baud search', 'baud watch', 'wait Prm', 'wait Cfg'][code] + ' (' + code + '×)' : (code === 0 ? 'DP ok' : '?');
  if (name === 'C') return code === 1 ? 'CAN ok' : MORSE[code] ? "Morse '" + MORSE[code] + "'" : (code === 0 ? 'off' : '?');
  return '';
}

// ---- diagnosis (manual §3.4, docs/dp-slave.md "Diagnosis"; names as in
// profibus_sim/dp/dp_telegram.hpp) ---
const DIAG_BITS = {
  0: ['Station_Non_Existent', 'Station_Not_Ready', 'Cfg_Fault', 'Ext_Diag', 'Not_Supported',
      'Invalid_Slave_Response', 'Prm_Fault', 'Master_Lock'],
  1: ['Prm_Req', 'Stat_Diag', 'always 1', 'WD_On', 'Freeze_Mode', 'Sync_Mode', 'reserved', 'Deactivated'],
  2: ['', '', '', '', '', '', '', 'Ext_Diag_Overflow'],
};
const BAD_BITS = { 0: 0x7D, 1: 0x00, 2: 0x80 };
const CAN_STATE = { 0x00: 'OK', 0x40: 'WARN', 0x80: 'ERROR_PASSIVE', 0xC0: 'BUS_OFF' };
function hex2(v) { return v.toString(16).toUpperCase().padStart(2, '0'); }
function diagText(i, d) {
  const v = d[i];
  if (i === 3) return v === 0xFF ? 'no master yet' : 'master ' + v;
  if (i === 4) return 'Ident ' + hex2(d[4]) + hex2(d[5]);
  if (i === 5) return '';
  if (i === 6) return 'ext. diag length';
  if (i === 7) return 'header';
  if (i === 8) {
    if (v === 0x3D) return 'Prm fault: telegram byte ' + d[9] + ', expected 0x' + hex2(d[10]);
    if (v === 0x3E) return 'Cfg fault: slot ' + d[9] + ', code ' + d[10];
    return 'CAN ' + (CAN_STATE[v & 0xC0] || '?');
  }
  if (i === 9) return d[8] === 0x3D || d[8] === 0x3E ? '' : 'IRQ_LOST ' + v;
  if (i === 10) return d[8] === 0x3D || d[8] === 0x3E ? '' : 'MSG_LOST ' + v;
  return '';
}

// ---- tiny DOM helpers --------------------------------------------------------------------------
function el(tag, attrs, ...kids) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === 'class') e.className = v; else if (k === 'text') e.textContent = v; else e.setAttribute(k, v);
  }
  for (const k of kids) e.append(k);
  return e;
}
function setText(e, t) { t = String(t); if (e.textContent !== t) e.textContent = t; }
function setClass(e, c) { if (e.className !== c) e.className = c; }
function ident(id, ext) {
  if (id === null || id === undefined) return '—';
  return '0x' + id.toString(16).toUpperCase().padStart(ext ? 8 : 3, '0');
}
function age(ms) {
  if (ms === null || ms === undefined) return '—';
  if (ms < 1000) return Math.round(ms) + ' ms';
  if (ms < 60000) return (ms / 1000).toFixed(1) + ' s';
  return Math.round(ms / 60000) + ' min';
}

// A time in microseconds in the unit that reads: 912 µs, 252.4 ms, 1.17 s.
function us(v) {
  if (v < 1000) return Math.round(v) + ' µs';
  if (v < 1e6) return (v / 1000).toFixed(1) + ' ms';
  return (v / 1e6).toFixed(2) + ' s';
}

// ---- a line plot on a canvas (no library) ------------------------------------------------------
// series: [{data, color, scale}]; a series with scale: false does not stretch the axis (drawn
// clipped to it). opts: points (the width in points), label, min, max, fmt (an axis label's text),
// left (the labels' width in pixels).

function plot(canvas, series, opts) {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth || 300, h = canvas.clientHeight || 120;
  if (canvas.width !== w * dpr) { canvas.width = w * dpr; canvas.height = h * dpr; }
  const g = canvas.getContext('2d');
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, w, h);
  let lo = opts.min ?? 0, hi = opts.max ?? 1;
  for (const s of series)
    if (s.scale !== false) for (const v of s.data) { hi = Math.max(hi, v); lo = Math.min(lo, v); }
  if (hi === lo) hi = lo + 1;
  const fmt = opts.fmt || (v => Math.abs(hi - lo) < 10 ? v.toFixed(1) : String(Math.round(v)));
  const pad = 16, n = opts.points, left = opts.left || 30;
  g.strokeStyle = '#2b3138'; g.lineWidth = 1; g.fillStyle = '#8a96a3'; g.font = '10px sans-serif';
  for (let k = 0; k <= 2; k++) {
    const y = pad + (h - 2 * pad) * k / 2;
    g.beginPath(); g.moveTo(left, y); g.lineTo(w - 4, y); g.stroke();
    const v = hi - (hi - lo) * k / 2;
    g.fillText(fmt(v), 2, y + 3);
  }
  g.fillText(opts.label || '', left + 4, h - 3);
  for (const s of series) {
    g.strokeStyle = s.color; g.fillStyle = s.color; g.lineWidth = 1.5; g.beginPath();
    s.data.forEach((v, i) => {
      const x = left + (w - left - 4) * (n - s.data.length + i) / Math.max(1, n - 1);
      const y = pad + (h - 2 * pad) * (hi - Math.min(hi, Math.max(lo, v))) / (hi - lo);
      i ? g.lineTo(x, y) : g.moveTo(x, y);
      if (s.data.length === 1) g.fillRect(x - 2, y - 2, 4, 4);  // one point: a dot, not nothing
    });
    g.stroke();
  }
}

// ---- the gateway panel -------------------------------------------------------------------------
const LEDS = [['P', 'green', 'power'], ['D', 'green', 'data exchange'], ['E', 'red', 'DP status'], ['C', 'green', 'CAN']];

function makePanel(g) {
  // The chart starts with what the page saw of this gateway already (its tile's frames/s).
  const seen = fpsSeen.get(g.dp_address) || { rx: [], tx: [] };
  const p = { leds: {}, diag: [], rates: { rx: [...seen.rx], tx: [...seen.tx], last: null } };
  const ledGrid = el('div', { class: 'leds' });
  for (const [name, color, what] of LEDS) {
    const led = el('div', { class: 'led ' + color, id: 'gw-' + g.dp_address + '-led-' + name, title: 'LED ' + name + ': ' + what, 'data-code': '0' });
    const meaning = el('div', { class: 'what' });
    p.leds[name] = { led, meaning, code: 0, color };
    ledGrid.append(el('div', { class: 'ledbox' }, el('div', { class: 'name', text: name }), led, meaning));
  }
  p.addr = el('div', { class: 'addr' });
  p.kv = {};
  const kv = el('dl', { class: 'kv' });
  for (const k of ['DP state', 'master', 'NMT', 'CAN', 'released', 'Data_Exch', 'Set_Prm']) {
    p.kv[k] = el('dd');
    kv.append(el('dt', { text: k }), p.kv[k]);
  }
  const plate = el('div', { class: 'plate' }, el('div', { class: 'model', text: 'CAN-DP/2' }),
    el('div', { class: 'maker', text: g.name + ' · bus ' + g.bus }), ledGrid,
    el('div', { class: 'hw', text: 'DP address' }), p.addr, kv);

  const dg = el('div', { class: 'diagbytes' });
  for (let i = 0; i < 11; i++) {
    const hexCell = el('span', { class: 'mono' });
    const bits = el('div', { class: 'bits' });
    const bitEls = [];
    if (DIAG_BITS[i]) {
      DIAG_BITS[i].forEach((name, b) => {
        if (!name) return;
        const be = el('span', { class: 'bit', title: 'byte ' + i + ' bit ' + b, text: name });
        bitEls.push([b, be]); bits.append(be);
      });
    }
    const txt = el('span');
    bits.append(txt);
    p.diag.push({ hexCell, bitEls, txt });
    dg.append(el('span', { class: 'n', text: i }), hexCell, bits);
  }
  const diag = el('div', { class: 'card diag' }, el('h3', { text: 'Slave diagnosis (bytes 0..10)' }), dg);

  p.prm = el('dl', { class: 'kv' });
  p.fifoBar = el('div'); p.fifoText = el('div', { class: 'hw' }); p.page = el('div', { class: 'hw' });
  const prm = el('div', { class: 'card prm' }, el('h3', { text: 'Parameters (Set_Prm user data)' }), p.prm,
    el('h3', { text: 'Communication Window FIFO', style: 'margin-top:10px' }),
    el('div', { class: 'meter fifo' }, p.fifoBar), p.fifoText,
    el('h3', { text: 'Page-Mode', style: 'margin-top:8px' }), p.page);

  p.slotBody = el('tbody');
  const slots = el('div', { class: 'card slots' }, el('h3', { text: 'Slots' }),
    el('table', {}, el('thead', {}, el('tr', {}, ...['slot', 'dir', 'kind', 'identifier', 'form', 'cycle', 'len', 'PLC', 'bytes', 'Rx/Tx', 'last update'].map(t => el('th', { text: t })))), p.slotBody));

  p.canvas = el('canvas');
  p.rateText = el('div', { class: 'legend' });
  const busplot = el('div', { class: 'card busplot' },
    el('div', {}, el('h3', { text: 'CAN frames/s, last minute' }), p.canvas,
      el('div', { class: 'legend' }, el('span', { class: 'rx', text: '— received ' }), el('span', { class: 'tx', text: '— sent' }))),
    el('div', {}, el('h3', { text: 'Counters' }), p.counters = el('dl', { class: 'kv' })));

  p.title = el('h2');
  p.root = el('article', { class: 'gw', id: 'gw-' + g.dp_address }, plate, diag, prm, slots, busplot);
  p.wrap = el('div', {}, p.title, p.root);
  document.getElementById('panel').append(p.wrap);
  plotRates(p);
  return p;
}

function plotRates(p) {
  const r = p.rates;
  p.canvas.dataset.points = String(r.rx.length);
  plot(p.canvas, [{ data: r.rx, color: '#35e06b' }, { data: r.tx, color: '#5fb3ff' }], { points: 60, label: '60 s' });
}

function kvSet(dl, pairs) {
  if (dl.childElementCount !== pairs.length * 2) {
    dl.replaceChildren(...pairs.flatMap(([k]) => [el('dt', { text: k }), el('dd')]));
  }
  pairs.forEach(([, v], i) => setText(dl.children[2 * i + 1], v));
}

// g: the gateway (the stream's "panel"); rows: its slot rows by index; nowMs: the event's time.
function updatePanel(p, g, rows, nowMs) {
  setText(p.title, 'Gateway ' + g.name + ' — DP address ' + g.dp_address);
  for (const [name] of LEDS) {
    const L = p.leds[name];
    L.code = g.leds[name];
    L.led.dataset.code = String(L.code);
    setText(L.meaning, ledMeaning(name, L.code));
  }
  setText(p.addr, String(g.dp_address).padStart(3, '0'));
  const st = (e, v, c) => { setText(e, v); setClass(e, c || ''); };
  st(p.kv['DP state'], g.dp_state, 'state-' + g.dp_state);
  st(p.kv['master'], g.master_state);
  // A gateway without CANopen has no NMT state (docs/canopen.md): none is shown.
  const canopen = g.parameters.canopen !== 'none';
  st(p.kv['NMT'], canopen ? g.nmt : '— (CANopen off)', canopen ? '' : 'dim');
  st(p.kv['CAN'], g.bus_state, g.bus_state === 'ok' || g.bus_state === 'OK' ? 'ok' : 'bad');
  st(p.kv['released'], g.released ? 'yes' : 'no', g.released ? 'ok' : 'warn');
  st(p.kv['Data_Exch'], g.counters.data_exchanges);
  st(p.kv['Set_Prm'], g.counters.parameterizations);

  g.diag.forEach((v, i) => {
    const d = p.diag[i];
    setText(d.hexCell, hex2(v));
    for (const [b, be] of d.bitEls) {
      const set = (v >> b) & 1;
      setClass(be, 'bit' + (set ? ' set' : '') + (set && (BAD_BITS[i] >> b) & 1 ? ' bad' : ''));
    }
    setText(d.txt, diagText(i, g.diag));
  });

  const q = g.parameters;
  kvSet(p.prm, [
    ['source', q.accepted ? 'accepted Set_Prm' : 'configured (not yet accepted)'],
    ['CAN bit rate', (q.bitrate / 1000) + ' kbit/s (index ' + q.bitrate_index + ')'],
    ['Comm. Window', q.comm_window ? 'on' : 'off'],
    ['RTR frames', q.send_rtr ? 'send' : "don't send"],
    ['CANopen', q.canopen],
    ['Start-Frame', q.start_frame ? 'on' : 'off'],
    ['Page-Mode', q.page_mode ? 'on' : 'off'],
    ['ModuleID', q.module_id],
    ['CAN-Diagnosis', q.can_diagnosis ? 'on' : 'off'],
    ['Rx/Tx-Counter', (q.rx_counter ? 'Rx ' : '') + (q.tx_counter ? 'Tx' : '') || 'off'],
    ['wake-up / SYNC', (q.wakeup_s === 255 ? 'keep' : q.wakeup_s + ' s') + ' / ' + (q.sync_ms === 65535 ? 'keep' : q.sync_ms + ' ms')],
    ['watchdog', q.watchdog_ms ? q.watchdog_ms + ' ms' : 'off'],
    ['user bytes', q.user_prm_hex],
  ]);
  const cap = 255;  // manual §5.3: the Communication Window FIFO holds 255 frames
  p.fifoBar.style.width = Math.min(100, 100 * g.fifo.level / cap) + '%';
  setText(p.fifoText, g.fifo.level + ' / ' + cap + ' frames · high-water ' + g.fifo.high_water);
  setText(p.page, g.page_mode.enabled ? g.page_mode.state + ' · ' + g.page_mode.pages_processed + ' pages' : 'off');

  // slot table
  const slots = rows.slice(0, g.slot_count).filter(Boolean);
  const trs = p.slotBody.rows;
  if (trs.length && trs[0].cells.length === 1) p.slotBody.deleteRow(0);
  while (trs.length > slots.length) p.slotBody.deleteRow(-1);
  slots.forEach((s, i) => {
    let r = trs[i];
    if (!r) {
      r = p.slotBody.insertRow();
      for (let k = 0; k < 11; k++) r.insertCell();
      r.cells[8].className = 'mono bytes';
      [3, 4, 7, 9].forEach(k => r.cells[k].className = 'mono');
    }
    r.dataset.slot = s.slot;
    const c = r.cells;
    setText(c[0], s.slot);
    setText(c[1], s.dir === 'rx' ? 'Rx' : 'Tx'); setClass(c[1], 'dir-' + s.dir);
    setText(c[2], s.kind);
    setText(c[3], s.id === null ? '—' : ident(s.id, s.extended) + (s.extended ? ' (29)' : ' (11)'));
    setText(c[4], '0x' + hex2(s.form));
    setText(c[5], s.cycle_ms ? s.cycle_ms + ' ms' : '—');
    setText(c[6], s.length);
    setText(c[7], s.plc || '—');
    setText(c[8], s.bytes);
    setText(c[9], s.frames);
    setText(c[10], age(s.last_ms === null ? null : Math.max(0, nowMs - s.last_ms)));
  });
  if (!slots.length) {
    // No slot configuration accepted yet (Chk_Cfg pending or rejected: see the diagnosis).
    const r = p.slotBody.insertRow();
    const c = r.insertCell();
    c.colSpan = 11; c.className = 'hw';
    c.textContent = 'no slot configuration accepted (' + g.dp_state + ', see the diagnosis)';
  }

  // frames/s from the counters, one point per second
  const r = p.rates;
  if (!r.last || nowMs - r.last.t >= 1000) {
    if (r.last) {
      const dt = (nowMs - r.last.t) / 1000;
      r.rx.push(Math.max(0, (g.counters.rx_frames - r.last.rx) / dt));
      r.tx.push(Math.max(0, (g.counters.tx_frames - r.last.tx) / dt));
      if (r.rx.length > 60) { r.rx.shift(); r.tx.shift(); }
      plotRates(p);
    }
    r.last = { t: nowMs, rx: g.counters.rx_frames, tx: g.counters.tx_frames };
  }
  kvSet(p.counters, [
    ['received', g.counters.rx_frames], ['sent', g.counters.tx_frames],
    ['rx/s, tx/s', r.rx.length ? Math.round(r.rx.at(-1)) + ', ' + Math.round(r.tx.at(-1))
      : tileFps(g.dp_address)],
    ['IRQ_LOST', g.counters.irq_lost], ['MSG_LOST', g.counters.msg_lost],
    ['SYNC', g.sync_ms ? g.sync_ms + ' ms' : 'off'],
  ]);
}

// ---- the panel's bus: load and the live trace ---------------------------------------------------
function makeBus(b) {
  const x = { frames: [], lastSeq: 0, paused: false };
  x.load = el('div'); x.loadText = el('div', { class: 'hw' }); x.info = el('dl', { class: 'kv' });
  x.fault = el('div', { class: 'tfault bfault', hidden: '' });  // CAN faults on cue in force
  x.filter = el('input', { placeholder: 'filter id, e.g. 181 or 201,202', size: '24' });
  x.pause = el('button', { text: 'pause' });
  x.pause.onclick = () => { x.paused = !x.paused; x.pause.textContent = x.paused ? 'resume' : 'pause'; x.pause.className = x.paused ? 'paused' : ''; };
  x.filter.oninput = () => renderTrace(x);
  x.body = el('tbody');
  // A bus in time (docs/can-bus.md "Seen from outside"): its exact load, a point a second, and
  // its identifiers' frames, period, jitter and queueing latency, its nodes' error counters and
  // state (docs/can-bus.md "Error confinement"); hidden on an ideal bus.
  x.loads = []; x.loadAt = 0;
  x.loadCanvas = el('canvas'); x.ids = el('tbody'); x.nodes = el('tbody');
  x.timed = el('div', { class: 'timed', hidden: '' },
    el('div', {}, el('h3', { text: 'Exact load, last minute' }), x.loadCanvas),
    el('div', {}, el('h3', { text: 'Identifiers (times in ms)' }),
      el('div', { class: 'trace' }, el('table', { class: 'ids' }, el('thead', {}, el('tr', {},
        ...['identifier', 'frames', 'period', 'jitter', 'latency last', 'mean', 'max'].map(t => el('th', { text: t })))), x.ids))),
    el('div', {}, el('h3', { text: 'Nodes (error confinement)' }),
      el('table', { class: 'nodes' }, el('thead', {}, el('tr', {},
        ...['node', 'TEC', 'REC', 'state'].map(t => el('th', { text: t })))), x.nodes)));
  x.root = el('div', { class: 'card bus', id: 'bus-' + b.name },
    el('div', {}, el('h2', { text: 'Bus ' + b.name }), el('h3', { text: 'Bus load' }), el('div', { class: 'meter' }, x.load), x.loadText, x.info, x.fault),
    el('div', {}, el('div', { class: 'tracebar' }, el('h3', { text: 'Live trace', style: 'margin:0' }), x.filter, x.pause),
      el('div', { class: 'trace' }, el('table', {}, el('thead', {}, el('tr', {}, ...['time', 'identifier', 'dlc', 'data'].map(t => el('th', { text: t })))), x.body))),
    x.timed);
  document.getElementById('panel').append(x.root);
  return x;
}
function renderTrace(x) {
  const want = x.filter.value.split(/[ ,]+/).filter(Boolean).map(s => parseInt(s, 16)).filter(n => !isNaN(n));
  const shown = x.frames.filter(f => !want.length || want.includes(f.id)).slice(-60).reverse();
  x.body.replaceChildren(...shown.map(f => el('tr', {},
    el('td', { class: 'mono', text: (f.t_ms / 1000).toFixed(3) }),
    el('td', { class: 'mono', text: ident(f.id, f.ext) }),
    el('td', { class: 'mono', text: f.rtr ? 'R' + f.dlc : f.dlc }),
    el('td', { class: 'mono', text: f.data }))));
}
function updateBus(x, b) {
  const pct = b.load_pct || 0;
  x.load.style.width = Math.min(100, pct) + '%';
  setText(x.loadText, pct.toFixed(1) + ' % of ' + (b.bitrate / 1000) + ' kbit/s');
  const timed = b.timed_bitrate !== undefined;
  kvSet(x.info, [['type', b.type], ['frames', b.frames], ['frames/s', Math.round(b.frames_per_s || 0)],
    ...(timed ? [['max load', b.load.max_pct.toFixed(1) + ' %'], ['lost', b.tx_lost], ['error frames', b.error_frames]] : [])]);
  x.timed.hidden = !timed;
  const faults = timed ? canFaultsText(b.faults || []) : '';
  setText(x.fault, faults);
  x.fault.hidden = !faults;
  if (timed) updateTimed(x, b);
}
// docs/can-bus.md "Seen from outside": each fault in force as the line shows a station's (its kind,
// then what is left of its time or count), with its node or identifier.
function canFaultsText(faults) {
  return faults.map(f => f.kind + (f.node ? ' ' + f.node : f.id !== null ? ' ' + ident(f.id, f.ext) : '') +
    (f.remaining_ms ? ' ' + f.remaining_ms + ' ms' : f.remaining ? ' ×' + f.remaining : '') +
    (f.every > 1 ? ', every ' + f.every : '')).join(' · ');
}
// docs/can-bus.md "Seen from outside": load_pct is then the exact load of the last second.
function updateTimed(x, b) {
  const now = Date.now();
  if (now - x.loadAt >= 1000) {
    x.loadAt = now;
    x.loads.push(b.load.last_pct);
    if (x.loads.length > 60) x.loads.shift();
  }
  x.loadCanvas.dataset.points = String(x.loads.length);
  plot(x.loadCanvas, [{ data: x.loads, color: '#35e06b' }], { points: 60, label: '60 s, %', max: 100 });
  const ms = v => v.toFixed(3);
  x.ids.replaceChildren(...b.identifiers.map(i => el('tr', { id: 'bus-' + b.name + '-id-' + i.id.toString(16).toUpperCase() + (i.rtr ? 'R' : '') },
    el('td', { class: 'mono', text: ident(i.id, i.ext) + (i.rtr ? ' R' : '') }),
    ...[String(i.frames), ms(i.period_ms), ms(i.jitter_ms), ms(i.latency_ms.last), ms(i.latency_ms.mean), ms(i.latency_ms.max)]
      .map(t => el('td', { class: 'mono', text: t })))));
  x.nodes.replaceChildren(...(b.nodes || []).map(n => el('tr', {},
    el('td', { class: 'mono', text: n.name }),
    ...[String(n.tec), String(n.rec), n.state].map(t => el('td', { class: 'mono', text: t })))));
}
// New frames of the trace (each event carries only the frames since the last one).
function addTrace(x, frames) {
  let added = false;
  for (const f of frames) if (f.seq > x.lastSeq) { x.frames.push(f); x.lastSeq = f.seq; added = true; }
  if (x.frames.length > 400) x.frames.splice(0, x.frames.length - 400);
  if (added && !x.paused) renderTrace(x);
}

// ---- drives on the panel's bus: state and speed ---------------------------------------------------
function makeDrive(d) {
  const x = { speed: [] };
  x.info = el('dl', { class: 'kv' }); x.canvas = el('canvas');
  x.root = el('div', { class: 'card drive', id: 'drive-' + d.name },
    el('div', {}, el('h2', { text: 'Drive ' + d.name }), x.info),
    el('div', {}, el('h3', { text: 'speed (actual), last minute' }), x.canvas));
  document.getElementById('panel').append(x.root);
  return x;
}
function updateDrive(x, d) {
  kvSet(x.info, [['bus', d.bus], ['enabled', d.enabled ? 'yes' : 'no'], ['mode', d.mode],
    ['speed', d.speed], ['position', d.position], ['status', '0x' + d.status.toString(16).toUpperCase().padStart(8, '0')]]);
  x.speed.push(d.speed);
  if (x.speed.length > 300) x.speed.shift();  // ~5 snapshots/s
  plot(x.canvas, [{ data: x.speed, color: '#ffb62e' }], { points: 300, label: '60 s', min: Math.min(0, ...x.speed) });
}

