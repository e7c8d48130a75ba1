// candp2 live front panel: a generic DP-V0 slave from its GSD (docs/slaves.md "Front panel and
// HTTP API"). Its overview tile (address, name, model, DP state, a fault line; no LEDs: a generic
// slave has no CAN-DP/2 front plate) and its panel (#slave=8): DP and master state, the whole
// diagnosis with the Station_Status bits named, the Ext_Diag bytes, the faults forced on it, the
// modules with their Chk_Cfg bytes, lengths, offsets and the current output and input bytes.
// Uses panel.js's helpers (el, setText, setClass, kvSet, hex2, DIAG_BITS); overview.js routes.
'use strict';

// Bits of Station_Status_1 that say something is wrong (the page marks them red).
const SLAVE_BAD_BITS = { 0: 0x5C, 1: 0x00, 2: 0x80 };

// ---- tile ---------------------------------------------------------------------------------------
function makeSlaveTile(t) {
  const x = { slave: true };
  x.addr = el('span', { class: 'taddr' });
  x.name = el('span', { class: 'tname' });
  x.model = el('div', { class: 'tmodel' });
  x.state = el('span', { class: 'tstate' });
  x.fault = el('div', { class: 'tfault' });
  x.root = el('a', { class: 'tile slave', id: 'tile-' + t.dp_address, href: '#slave=' + t.dp_address },
    el('div', { class: 'thead' }, x.addr, x.name), x.model, x.state, x.fault);
  document.getElementById('tiles').append(x.root);
  return x;
}
function updateSlaveTile(x, t) {
  setText(x.addr, String(t.dp_address).padStart(3, '0'));
  setText(x.name, t.name + ' · slave');
  setText(x.model, t.model + (t.kind === 'line' ? ' · line' : ''));
  setText(x.state, t.dp_state);
  setClass(x.state, 'tstate state-' + t.dp_state);
  setText(x.fault, t.fault || '');
  setClass(x.root, 'tile slave' + (t.fault ? ' faulty' : ''));
}

// ---- panel --------------------------------------------------------------------------------------
function makeSlavePanel(s) {
  const p = {};
  p.addr = el('div', { class: 'addr' });
  p.kv = el('dl', { class: 'kv' });
  const plate = el('div', { class: 'plate' }, el('div', { class: 'model', text: s.gsd.model }),
    el('div', { class: 'maker', text: s.gsd.vendor }), el('div', { class: 'hw', text: 'DP address' }),
    p.addr, p.kv);
  p.diag = el('div', { class: 'diagbytes' });
  p.ext = el('div', { class: 'mono ext' });
  const diag = el('div', { class: 'card diag' }, el('h3', { text: 'Slave diagnosis' }), p.diag,
    el('h3', { text: 'Ext_Diag_Data', style: 'margin-top:8px' }), p.ext);
  p.faults = el('dl', { class: 'kv' });
  const faults = el('div', { class: 'card prm' }, el('h3', { text: 'Faults and parameterization' }), p.faults);
  p.body = el('tbody');
  const heads = ['slot', 'module', 'Cfg', 'in', 'out', 'in at', 'out at', 'PLC', 'outputs (master)', 'inputs (field)'];
  const modules = el('div', { class: 'card slots modules' }, el('h3', { text: 'Modules' }),
    el('table', {}, el('thead', {}, el('tr', {}, ...heads.map(t => el('th', { text: t })))), p.body));
  p.title = el('h2');
  p.root = el('article', { class: 'gw slave', id: 'slave-' + s.dp_address }, plate, diag, faults, modules);
  p.wrap = el('div', {}, p.title, p.root);
  document.getElementById('panel').append(p.wrap);
  return p;
}

function slaveDiagRows(p, d) {
  // 0..2 Station_Status with named bits, 3 the master holding the lock, 4..5 the Ident_Number.
  const n = Math.min(6, d.length);
  if (p.diag.childElementCount !== 3 * n) {
    p.diag.replaceChildren();
    p.diagRows = [];
    for (let i = 0; i < n; i++) {
      const hexCell = el('span', { class: 'mono' });
      const bits = el('div', { class: 'bits' });
      const bitEls = [];
      (DIAG_BITS[i] || []).forEach((name, b) => {
        if (!name) return;
        const be = el('span', { class: 'bit', title: 'byte ' + i + ' bit ' + b, text: name });
        bitEls.push([b, be]); bits.append(be);
      });
      const txt = el('span');
      bits.append(txt);
      p.diagRows.push({ hexCell, bitEls, txt });
      p.diag.append(el('span', { class: 'n', text: i }), hexCell, bits);
    }
  }
  p.diagRows.forEach((r, i) => {
    const v = d[i];
    setText(r.hexCell, hex2(v));
    for (const [b, be] of r.bitEls) {
      const set = (v >> b) & 1;
      setClass(be, 'bit' + (set ? ' set' : '') + (set && (SLAVE_BAD_BITS[i] >> b) & 1 ? ' bad' : ''));
    }
    let text = '';
    if (i === 3) text = v === 0xFF ? 'no master holds the lock' : 'locked by master ' + v;
    if (i === 4) text = 'Ident_Number 0x' + hex2(d[4]) + hex2(d[5]);
    setText(r.txt, text);
  });
}

function updateSlavePanel(p, s) {
  setText(p.title, 'Slave ' + s.name + ' — DP address ' + s.dp_address);
  setText(p.addr, String(s.dp_address).padStart(3, '0'));
  const m = s.master;
  kvSet(p.kv, [
    ['DP state', s.dp_state],
    ['master', m ? m.state : '— (external)'],
    ['Data_Exch', m ? m.data_exchanges : '—'],
    ['Set_Prm', m ? m.parameterizations : '—'],
    ['addressed', m ? (m.addressed ? 'yes' : 'no') : '—'],
    ['where', s.kind],
    ['GSD', s.gsd.file.split('/').pop()],
    ['Ident', '0x' + s.gsd.ident_number.toString(16).toUpperCase().padStart(4, '0')],
    ['field unit', s.field_unit === null ? '—' : s.field_unit],
    ['watchdog', s.watchdog_ms ? s.watchdog_ms + ' ms' : 'off'],
  ]);
  setClass(p.kv.children[1], 'state-' + s.dp_state);
  slaveDiagRows(p, s.diag);
  setText(p.ext, s.diagnosis.ext_diag_hex || '(none)');
  const f = s.faults;
  const rows = [  // [name, value, shown as a fault]
    ['on the bus', f.on_bus ? 'yes' : 'no (left the bus)', !f.on_bus],
    ['Prm fault forced', f.prm_fault ? 'yes' : 'no', f.prm_fault],
    ['Cfg fault forced', f.cfg_fault ? 'yes' : 'no', f.cfg_fault],
    ['diagnosis alarm', f.alarm_hex === null ? 'none' : f.alarm_hex, f.alarm_hex !== null],
    ['last Set_Prm', s.prm_problem || 'accepted', !!s.prm_problem],
    ['last Chk_Cfg', s.cfg_problem || 'accepted', !!s.cfg_problem],
    ['I/O bytes', s.input_length + ' in, ' + s.output_length + ' out', false],
  ];
  kvSet(p.faults, rows.map(([k, v]) => [k, v]));
  rows.forEach(([, , bad], i) => setClass(p.faults.children[2 * i + 1], bad ? 'bad' : ''));
  const trs = p.body.rows;
  while (trs.length > s.modules.length) p.body.deleteRow(-1);
  s.modules.forEach((mod, i) => {
    let r = trs[i];
    if (!r) {
      r = p.body.insertRow();
      for (let k = 0; k < 10; k++) r.insertCell();
      [2, 7].forEach(k => r.cells[k].className = 'mono');
      r.cells[8].className = 'mono bytes out';
      r.cells[9].className = 'mono bytes in';
    }
    r.dataset.module = mod.name;
    const c = r.cells;
    setText(c[0], i + 1);
    setText(c[1], mod.name);
    setText(c[2], mod.cfg_hex);
    setText(c[3], mod.inputs);
    setText(c[4], mod.outputs);
    setText(c[5], mod.inputs ? mod.input_offset : '—');
    setText(c[6], mod.outputs ? mod.output_offset : '—');
    setText(c[7], [mod.plc_inputs, mod.plc_outputs].filter(Boolean).join(' ') || '—');
    setText(c[8], mod.outputs ? mod.output_bytes : '—');
    setText(c[9], mod.inputs ? mod.input_bytes : '—');
  });
}
