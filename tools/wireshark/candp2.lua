-- candp2.lua: a Wireshark dissector for PROFIBUS FDL telegrams, the DP-V0 services in them and
-- the esd CAN-DP/2 gateway's payloads (docs/capture.md). Written for candp2's pcapng captures
-- (the "fdl" exported-PDU dissector name, LINKTYPE_WIRESHARK_UPPER_PDU 252) and the notes in
-- them ("candp2"). Three protocol layers, each with display-filter fields named layer.field:
--   fdl     layer 2 as IEC 61158-4-3 (type 3) / EN 50170 vol. 2 lay it out: SD1/SD2/SD3/SD4/SC,
--           LE/LEr, DA/SA with address extensions (DSAP/SSAP), FC (request/response function,
--           FCB/FCV, station type), the FCS (checked: expert info when wrong), ED;
--   dp      the DP-V0 services by SAP and direction (EN 50170 vol. 2 DP): Set_Prm, Chk_Cfg/Get_Cfg
--           identifier bytes, Slave_Diag status bytes, Global_Control, Data_Exchange, FDL_Status;
--   candp2  what the CAN-DP/2 makes of them (esd CAN-DP/2 manual): the Set_Prm user parameters
--           (manual §5.1.2, table 5.1.1), the Chk_Cfg slots from their comment bytes with CAN
--           identifier, form and cycle (manual §5.2, §5.3.2 Communication Window, §6.4 Page-Mode
--           segments), the extended diagnosis bytes 8..10 (manual §3.4.2, table 3.4.5), and the
--           Data_Exchange bytes split into those slots.
-- Written from the standards and the manual for candp2; it follows no other project's dissector.
-- Install: /usr/share/candp2/wireshark/candp2.lua (the Debian package) copied or linked into
-- ~/.local/lib/wireshark/plugins/, or for one run: tshark -X lua_script:candp2.lua -r CAPTURE.

local p_fdl = Proto("fdl", "PROFIBUS FDL (IEC 61158-4-3)")
local p_dp = Proto("dp", "PROFIBUS DP-V0 (EN 50170 vol. 2)")
local p_cdp = Proto("candp2", "esd CAN-DP/2")

-- Wireshark's Lua is 5.2 in 4.0 (no bit operators): its built-in "bit" library does them.
local band, shr = bit.band, bit.rshift
local function has(v, mask) return band(v, mask) ~= 0 end

---------------------------------------------------------------------------------- FDL constants
local SD1, SD2, SD3, SD4, SC, ED = 0x10, 0x68, 0xA2, 0xDC, 0xE5, 0x16
local sd_names = { [SD1] = "SD1", [SD2] = "SD2", [SD3] = "SD3", [SD4] = "SD4", [SC] = "SC" }
local req_functions = {
  [0x0] = "Time_Event", [0x3] = "SDA_low", [0x4] = "SDN_low", [0x5] = "SDA_high",
  [0x6] = "SDN_high", [0x7] = "MSRD", [0x9] = "FDL_Status", [0xC] = "SRD_low",
  [0xD] = "SRD_high", [0xE] = "Ident", [0xF] = "LSAP_Status",
}
local res_functions = {
  [0x0] = "OK", [0x1] = "UE", [0x2] = "RR", [0x3] = "RS", [0x8] = "DL", [0x9] = "NR",
  [0xA] = "DH", [0xC] = "RDL", [0xD] = "RDH",
}
local station_types = {
  [0] = "slave", [1] = "master not ready", [2] = "master ready", [3] = "master in ring",
}

-- DP services: the slave's SAP (EN 50170 vol. 2), plus the default SAP and FDL_Status.
local S_DX, S_FDL_STATUS, S_TOKEN, S_OTHER = 1, 2, 3, 4
local services = {
  [S_DX] = "Data_Exchange", [S_FDL_STATUS] = "FDL_Status", [S_TOKEN] = "Token",
  [S_OTHER] = "other SAP", [54] = "MM", [55] = "Set_Slave_Add", [56] = "Rd_Inp",
  [57] = "Rd_Outp", [58] = "Global_Control", [59] = "Get_Cfg", [60] = "Slave_Diag",
  [61] = "Set_Prm", [62] = "Chk_Cfg",
}
local function service_of_sap(sap) return services[sap] and sap >= 54 and sap or S_OTHER end

----------------------------------------------------------------------------------- FDL fields
local F = {}
local function field(proto, f) proto.fields[#proto.fields + 1] = f; return f end
p_fdl.fields = {}
F.sd = field(p_fdl, ProtoField.uint8("fdl.sd", "Start delimiter", base.HEX, sd_names))
F.kind = field(p_fdl, ProtoField.string("fdl.kind", "Telegram"))
F.le = field(p_fdl, ProtoField.uint8("fdl.le", "LE"))
F.ler = field(p_fdl, ProtoField.uint8("fdl.ler", "LEr"))
F.da = field(p_fdl, ProtoField.uint8("fdl.da", "DA (destination)", base.DEC, nil, 0x7F))
F.da_ext = field(p_fdl, ProtoField.bool("fdl.da.ext", "DSAP follows", 8, nil, 0x80))
F.sa = field(p_fdl, ProtoField.uint8("fdl.sa", "SA (source)", base.DEC, nil, 0x7F))
F.sa_ext = field(p_fdl, ProtoField.bool("fdl.sa.ext", "SSAP follows", 8, nil, 0x80))
F.fc = field(p_fdl, ProtoField.uint8("fdl.fc", "FC", base.HEX))
F.fc_req = field(p_fdl, ProtoField.bool("fdl.fc.req", "Request", 8, nil, 0x40))
F.fc_fcb = field(p_fdl, ProtoField.bool("fdl.fc.fcb", "FCB", 8, nil, 0x20))
F.fc_fcv = field(p_fdl, ProtoField.bool("fdl.fc.fcv", "FCV", 8, nil, 0x10))
F.fc_stype = field(p_fdl, ProtoField.uint8("fdl.fc.stype", "Station type", base.DEC,
  station_types, 0x30))
F.fc_reqfn = field(p_fdl, ProtoField.uint8("fdl.fc.function", "Function", base.HEX,
  req_functions, 0x0F))
F.fc_resfn = field(p_fdl, ProtoField.uint8("fdl.fc.status", "Response", base.HEX,
  res_functions, 0x0F))
F.dsap = field(p_fdl, ProtoField.uint8("fdl.dsap", "DSAP", base.DEC, nil, 0x3F))
F.ssap = field(p_fdl, ProtoField.uint8("fdl.ssap", "SSAP", base.DEC, nil, 0x3F))
F.du = field(p_fdl, ProtoField.bytes("fdl.du", "Data unit"))
F.fcs = field(p_fdl, ProtoField.uint8("fdl.fcs", "FCS", base.HEX))
F.fcs_ok = field(p_fdl, ProtoField.bool("fdl.fcs.ok", "FCS correct"))
F.ed = field(p_fdl, ProtoField.uint8("fdl.ed", "End delimiter", base.HEX))
F.request_in = field(p_fdl, ProtoField.framenum("fdl.request_in", "Answers the request in"))
local E = {
  fcs = ProtoExpert.new("fdl.fcs.bad", "FCS wrong", expert.group.CHECKSUM, expert.severity.ERROR),
  le = ProtoExpert.new("fdl.le.bad", "LE wrong", expert.group.MALFORMED, expert.severity.ERROR),
  ed = ProtoExpert.new("fdl.ed.bad", "End delimiter missing", expert.group.MALFORMED,
    expert.severity.ERROR),
  short = ProtoExpert.new("fdl.short", "Telegram truncated", expert.group.MALFORMED,
    expert.severity.ERROR),
  sd = ProtoExpert.new("fdl.sd.bad", "No start delimiter", expert.group.MALFORMED,
    expert.severity.ERROR),
  trailing = ProtoExpert.new("fdl.trailing", "Bytes after the telegram", expert.group.MALFORMED,
    expert.severity.WARN),
  sap = ProtoExpert.new("fdl.sap.bad", "Address extension bits 7..6 set", expert.group.MALFORMED,
    expert.severity.WARN),
  dp_short = ProtoExpert.new("dp.short", "DP data too short", expert.group.MALFORMED,
    expert.severity.WARN),
  cfg = ProtoExpert.new("candp2.slot.bad", "Slot the gateway cannot decode (Cfg fault)",
    expert.group.PROTOCOL, expert.severity.NOTE),
}
p_fdl.experts = { E.fcs, E.le, E.ed, E.short, E.sd, E.trailing, E.sap }

------------------------------------------------------------------------------------ DP fields
p_dp.fields = {}
F.service = field(p_dp, ProtoField.uint8("dp.service", "Service", base.DEC, services))
F.response = field(p_dp, ProtoField.bool("dp.response", "Response"))
F.changed = field(p_dp, ProtoField.bool("dp.changed", "Data changed since the previous exchange"))
F.prm_status = field(p_dp, ProtoField.uint8("dp.prm.station_status", "Station_Status", base.HEX))
F.prm_lock = field(p_dp, ProtoField.bool("dp.prm.lock_req", "Lock_Req", 8, nil, 0x80))
F.prm_unlock = field(p_dp, ProtoField.bool("dp.prm.unlock_req", "Unlock_Req", 8, nil, 0x40))
F.prm_sync = field(p_dp, ProtoField.bool("dp.prm.sync_req", "Sync_Req", 8, nil, 0x20))
F.prm_freeze = field(p_dp, ProtoField.bool("dp.prm.freeze_req", "Freeze_Req", 8, nil, 0x10))
F.prm_wd_on = field(p_dp, ProtoField.bool("dp.prm.wd_on", "WD_On", 8, nil, 0x08))
F.prm_wd1 = field(p_dp, ProtoField.uint8("dp.prm.wd_fact_1", "WD_Fact_1"))
F.prm_wd2 = field(p_dp, ProtoField.uint8("dp.prm.wd_fact_2", "WD_Fact_2"))
F.prm_wd_ms = field(p_dp, ProtoField.uint32("dp.prm.watchdog_ms", "Watchdog (ms)"))
F.prm_tsdr = field(p_dp, ProtoField.uint8("dp.prm.min_tsdr", "min_TSDR (bit times)"))
F.prm_ident = field(p_dp, ProtoField.uint16("dp.prm.ident", "Ident_Number", base.HEX))
F.prm_group = field(p_dp, ProtoField.uint8("dp.prm.group", "Group_Ident", base.HEX))
F.prm_user = field(p_dp, ProtoField.bytes("dp.prm.user", "User_Prm_Data"))
F.cfg_entry = field(p_dp, ProtoField.uint8("dp.cfg.id", "Identifier byte", base.HEX))
F.cfg_format = field(p_dp, ProtoField.string("dp.cfg.format", "Format"))
F.cfg_io = field(p_dp, ProtoField.string("dp.cfg.io", "Direction"))
F.cfg_len = field(p_dp, ProtoField.uint8("dp.cfg.length", "Length (units)"))
F.cfg_cons = field(p_dp, ProtoField.bool("dp.cfg.consistent", "Consistency over the whole length"))
F.cfg_words = field(p_dp, ProtoField.bool("dp.cfg.words", "Unit: words"))
F.cfg_manuf = field(p_dp, ProtoField.bytes("dp.cfg.manufacturer", "Manufacturer bytes"))
F.diag1 = field(p_dp, ProtoField.uint8("dp.diag.status1", "Station_Status_1", base.HEX))
local diag1_bits = {
  { "non_existent", "Station_Non_Existent", 0x01 }, { "not_ready", "Station_Not_Ready", 0x02 },
  { "cfg_fault", "Cfg_Fault", 0x04 }, { "ext_diag", "Ext_Diag", 0x08 },
  { "not_supported", "Not_Supported", 0x10 }, { "invalid_response", "Invalid_Slave_Response", 0x20 },
  { "prm_fault", "Prm_Fault", 0x40 }, { "master_lock", "Master_Lock", 0x80 },
}
local diag2_bits = {
  { "prm_req", "Prm_Req", 0x01 }, { "stat_diag", "Stat_Diag", 0x02 }, { "always1", "(always 1)", 0x04 },
  { "wd_on", "WD_On", 0x08 }, { "freeze", "Freeze_Mode", 0x10 }, { "sync", "Sync_Mode", 0x20 },
  { "deactivated", "Deactivated", 0x80 },
}
for _, b in ipairs(diag1_bits) do
  F["d1_" .. b[1]] = field(p_dp, ProtoField.bool("dp.diag." .. b[1], b[2], 8, nil, b[3]))
end
F.diag2 = field(p_dp, ProtoField.uint8("dp.diag.status2", "Station_Status_2", base.HEX))
for _, b in ipairs(diag2_bits) do
  F["d2_" .. b[1]] = field(p_dp, ProtoField.bool("dp.diag." .. b[1], b[2], 8, nil, b[3]))
end
F.diag3 = field(p_dp, ProtoField.uint8("dp.diag.status3", "Station_Status_3", base.HEX))
F.diag_master = field(p_dp, ProtoField.uint8("dp.diag.master", "Master address"))
F.diag_ident = field(p_dp, ProtoField.uint16("dp.diag.ident", "Ident_Number", base.HEX))
F.diag_ext = field(p_dp, ProtoField.bytes("dp.diag.ext", "Ext_Diag_Data"))
F.gc_control = field(p_dp, ProtoField.uint8("dp.gc.control", "Control_Command", base.HEX))
F.gc_group = field(p_dp, ProtoField.uint8("dp.gc.group", "Group_Select", base.HEX))
F.outputs = field(p_dp, ProtoField.bytes("dp.outputs", "Outputs"))
F.inputs = field(p_dp, ProtoField.bytes("dp.inputs", "Inputs"))
p_dp.experts = { E.dp_short }

-------------------------------------------------------------------------------- CAN-DP/2 fields
local bitrates = { -- manual table 5.1.1, kbit/s
  [0] = "1000k", "666.6k", "500k", "333.3k", "250k", "166k", "125k", "100k", "66.6k", "50k",
  "33.3k", "20k", "12.5k", "10k",
}
local cfg_codes = { -- manual §3.4.2 list; 7..10 documented in docs/decisions.md and gateway/
  [1] = "wrong I/O type", [2] = "wrong unit", [3] = "wrong length", [4] = "identifier missing",
  [5] = "format byte missing", [6] = "wrong identifier", [7] = "limits exceeded",
  [8] = "Communication Window misconfigured", [9] = "Page-Mode segment layout broken",
  [10] = "no output slot",
}
local bus_states = { [0x00] = "OK", [0x40] = "WARN", [0x80] = "ERROR_PASSIVE", [0xC0] = "BUS_OFF" }
p_cdp.fields = {}
F.note = field(p_cdp, ProtoField.string("candp2.note", "Note"))
F.bitrate = field(p_cdp, ProtoField.uint8("candp2.prm.bitrate", "CAN bit rate", base.DEC, bitrates))
F.flags = field(p_cdp, ProtoField.uint8("candp2.prm.flags", "Mode flags", base.HEX))
local flag_bits = {
  { "cw", "Communication-Window", 0x80 }, { "no_rtr", "No RTR frames", 0x10 },
  { "canopen_slave", "CANopen-Slave", 0x08 }, { "canopen_master", "CANopen-Master", 0x04 },
  { "start_frame", "Start-Frame", 0x02 }, { "page_mode", "Page-Mode", 0x01 },
}
for _, b in ipairs(flag_bits) do
  F["fl_" .. b[1]] = field(p_cdp, ProtoField.bool("candp2.prm." .. b[1], b[2], 8, nil, b[3]))
end
F.module_id = field(p_cdp, ProtoField.uint8("candp2.prm.module_id", "ModuleID"))
F.diag_flags = field(p_cdp, ProtoField.uint8("candp2.prm.diag_flags", "Diagnosis flags", base.HEX))
F.can_diag = field(p_cdp, ProtoField.bool("candp2.prm.can_diagnosis", "CAN-Diagnosis", 8, nil, 0x01))
F.rx_counter = field(p_cdp, ProtoField.bool("candp2.prm.rx_counter", "Rx-Counter", 8, nil, 0x02))
F.tx_counter = field(p_cdp, ProtoField.bool("candp2.prm.tx_counter", "Tx-Counter", 8, nil, 0x04))
F.wakeup = field(p_cdp, ProtoField.uint8("candp2.prm.wakeup_s", "Wake-up time (s, 255 = keep)"))
F.sync = field(p_cdp, ProtoField.uint16("candp2.prm.sync_ms", "SYNC time (ms, 65535 = keep)"))
F.reserved = field(p_cdp, ProtoField.uint8("candp2.prm.reserved", "Reserved", base.HEX))
F.slot = field(p_cdp, ProtoField.uint8("candp2.slot", "Slot"))
F.slot_kind = field(p_cdp, ProtoField.string("candp2.slot.kind", "Kind"))
F.slot_id = field(p_cdp, ProtoField.uint32("candp2.slot.id", "CAN identifier", base.HEX))
F.slot_ext = field(p_cdp, ProtoField.bool("candp2.slot.id29", "29-bit identifier"))
F.slot_dummy = field(p_cdp, ProtoField.bool("candp2.slot.dummy", "Dummy output (07F8: nothing sent)"))
F.slot_form = field(p_cdp, ProtoField.uint8("candp2.slot.form", "form", base.HEX))
F.slot_cycle = field(p_cdp, ProtoField.uint16("candp2.slot.cycle_ms", "Cycle (ms)"))
F.slot_cwsync = field(p_cdp, ProtoField.uint16("candp2.slot.cw_sync_ms", "CW SYNC time (ms)"))
F.slot_len = field(p_cdp, ProtoField.uint8("candp2.slot.length", "Length in the DP image"))
F.slot_counter = field(p_cdp, ProtoField.bool("candp2.slot.counter", "Last byte is the counter"))
F.slot_offset = field(p_cdp, ProtoField.uint16("candp2.slot.offset", "Offset in the DP image"))
F.slot_data = field(p_cdp, ProtoField.bytes("candp2.slot.data", "Data"))
F.can_station = field(p_cdp, ProtoField.uint8("candp2.can.station", "Gateway (DP address)"))
F.can_data = field(p_cdp, ProtoField.bytes("candp2.can.data", "CAN data"))
F.diag_sap = field(p_cdp, ProtoField.uint8("candp2.diag.sap", "Faulty service", base.HEX,
  { [0x3D] = "Set_Prm (SAP 61)", [0x3E] = "Chk_Cfg (SAP 62)" }))
F.prm_byte = field(p_cdp, ProtoField.uint8("candp2.diag.prm_byte", "Faulty Set_Prm byte"))
F.prm_correct = field(p_cdp, ProtoField.uint8("candp2.diag.prm_correct", "Correct value", base.HEX))
F.cfg_slot = field(p_cdp, ProtoField.uint8("candp2.diag.cfg_slot", "Faulty slot"))
F.cfg_code = field(p_cdp, ProtoField.uint8("candp2.diag.cfg_code", "Cfg fault", base.DEC, cfg_codes))
F.bus_state = field(p_cdp, ProtoField.uint8("candp2.diag.bus_state", "CAN bus state", base.HEX,
  bus_states))
F.irq_lost = field(p_cdp, ProtoField.uint8("candp2.diag.irq_lost", "IRQ_LOST"))
F.msg_lost = field(p_cdp, ProtoField.uint8("candp2.diag.msg_lost", "MSG_LOST"))
p_cdp.experts = { E.cfg }

--------------------------------------------------------------------------------------- state
-- Per capture interface: the last request (an SC answer carries no addresses); per interface
-- and station: the CAN-DP/2 user parameters and slots last sent. Saved per frame on the first
-- pass, so a frame clicked later shows what it showed in order.
local f_interface = Field.new("frame.interface_id")
local f_can_id, f_can_xtd = Field.new("can.id"), Field.new("can.flags.xtd")
local last_request, stations, frames, can_ids, can_frames

local function reset()
  last_request, stations, frames, can_ids, can_frames = {}, {}, {}, {}, {}
end
reset()
p_fdl.init = reset  -- a new capture file

local function station_state(iface, station)
  local key = iface .. ":" .. station
  stations[key] = stations[key] or { station = station }
  return stations[key]
end

-- CAN identifiers of every station's slots (for the CAN frames' meaning), rebuilt when a
-- station's slots change.
local function index_can_ids()
  can_ids = {}
  for _, st in pairs(stations) do
    for _, sl in ipairs(st.slots or {}) do
      if sl.id and not sl.dummy then
        local key = (sl.ext and "x" or "s") .. sl.id
        can_ids[key] = can_ids[key] or {}
        table.insert(can_ids[key], { station = st.station, slot = sl })
      end
    end
  end
end

local function hex(range)
  return range:bytes():tohex(false, " ")
end

------------------------------------------------------------------------------- CAN-DP/2 slots
-- A slot from one Chk_Cfg entry (manual §5.2: special identifier format, the comment bytes give
-- the CAN identifier, form and cycle; §5.3.2: FF EF = Communication Window; §6.4: in Page-Mode
-- every other entry is a 32-byte segment).
local function slot_of(e, prm)
  local s = { index = e.index, length = e.len, input = e.input, entry = e }
  local m = e.manuf
  if e.io ~= "input" and e.io ~= "output" or e.words then s.bad = true; return s end
  local cw = #m >= 2 and m[1] == 0xFF and m[2] == 0xEF
  if cw then
    s.kind = e.input and "cw-in" or "cw-out"
    if #m ~= 3 and #m ~= 5 then s.bad = true; return s end
    s.form = m[3]
    if #m == 5 then s.cw_sync = m[4] * 256 + m[5] end
    return s
  end
  if prm and prm.page_mode then s.kind = e.input and "segment-in" or "segment-out"; return s end
  s.kind = e.input and "rx" or "tx"
  s.counter = prm and ((e.input and prm.rx_counter) or (not e.input and prm.tx_counter)) or false
  local bit29 = #m >= 1 and has(m[1], 0x20)
  local pos
  if #m == 3 or (#m == 5 and not bit29) then
    s.id, pos = m[1] * 256 + m[2], 3
  elseif (#m == 5 or #m == 7) and bit29 then
    s.id = band(m[1], 0x1F) * 0x1000000 + m[2] * 0x10000 + m[3] * 0x100 + m[4]
    s.ext, pos = true, 5
  else
    s.bad = true
    return s
  end
  s.form = m[pos]
  if pos + 2 <= #m and not e.input then s.cycle = m[pos + 1] * 256 + m[pos + 2] end
  if not e.input and not s.ext and s.id == 0x7F8 then s.dummy = true end
  return s
end

local function slot_text(s)
  if s.bad then return "slot" .. s.index .. " (not decodable)" end
  local t = "slot" .. s.index .. " " .. s.kind
  if s.dummy then t = t .. " dummy"
  elseif s.id then t = t .. string.format(s.ext and " %08X" or " %03X", s.id) end
  t = t .. " " .. s.length .. "B"
  if s.form then t = t .. string.format(" form %02X", s.form) end
  if s.cycle and s.cycle > 0 then t = t .. " cycle " .. s.cycle .. " ms" end
  return t
end

local function add_slot(tree, range, s)
  local st = tree:add(p_cdp, range, slot_text(s))
  st:add(F.slot, range, s.index):set_generated()
  if s.bad then st:add_proto_expert_info(E.cfg); return end
  st:add(F.slot_kind, range, s.kind):set_generated()
  if s.id then
    st:add(F.slot_id, range, s.id):set_generated()
    st:add(F.slot_ext, range, s.ext or false):set_generated()
  end
  if s.dummy then st:add(F.slot_dummy, range, true):set_generated() end
  if s.form then st:add(F.slot_form, range, s.form):set_generated() end
  if s.cycle then st:add(F.slot_cycle, range, s.cycle):set_generated() end
  if s.cw_sync then st:add(F.slot_cwsync, range, s.cw_sync):set_generated() end
  st:add(F.slot_len, range, s.length):set_generated()
  if s.counter then st:add(F.slot_counter, range, true):set_generated() end
  if s.offset then st:add(F.slot_offset, range, s.offset):set_generated() end
end

-------------------------------------------------------------------------------- DP payloads
-- Chk_Cfg / Get_Cfg identifier bytes (EN 50170 vol. 2 DP: general and special format).
local function dissect_cfg(tvb, tree, prm)
  local entries, pos, n = {}, 0, tvb:len()
  local offsets = { input = 0, output = 0 }
  while pos < n do
    local id = tvb(pos, 1):uint()
    local e = { index = #entries, manuf = {} }
    local start = pos
    pos = pos + 1
    if has(id, 0x30) then
      e.special = false
      e.io = ({ [1] = "input", [2] = "output", [3] = "input+output" })[band(shr(id, 4), 3)]
      e.len, e.cons, e.words = band(id, 0x0F) + 1, has(id, 0x80), has(id, 0x40)
    else
      e.special = true
      local io = band(shr(id, 6), 3)
      e.io = ({ [0] = "empty", "input", "output", "input+output" })[io]
      local m = band(id, 0x0F)
      local lens = io == 3 and 2 or (io == 0 and 0 or 1)
      if pos + lens + m > n then
        local t = tree:add(p_dp, tvb(start, n - start), "Truncated Chk_Cfg entry")
        t:add_proto_expert_info(E.dp_short)
        break
      end
      if lens > 0 then
        local l = tvb(pos, 1):uint()
        e.len, e.cons, e.words = band(l, 0x3F) + 1, has(l, 0x80), has(l, 0x40)
      end
      pos = pos + lens
      for i = 0, m - 1 do e.manuf[#e.manuf + 1] = tvb(pos + i, 1):uint() end
      pos = pos + m
    end
    e.input = e.io == "input"
    local range = tvb(start, pos - start)
    local et = tree:add(p_dp, range, string.format("Entry %d: %s %s %s", e.index,
      e.special and "special" or "general", e.io, e.len and (e.len .. (e.words and "W" or "B")) or ""))
    et:add(F.cfg_entry, tvb(start, 1))
    et:add(F.cfg_format, range, e.special and "special" or "general"):set_generated()
    et:add(F.cfg_io, range, e.io):set_generated()
    if e.len then
      et:add(F.cfg_len, range, e.len):set_generated()
      et:add(F.cfg_cons, range, e.cons):set_generated()
      et:add(F.cfg_words, range, e.words):set_generated()
    end
    if #e.manuf > 0 then et:add(F.cfg_manuf, tvb(pos - #e.manuf, #e.manuf)) end
    if prm and prm.candp2 then
      local s = slot_of(e, prm)
      if not s.bad and e.len then
        local dir = e.input and "input" or "output"
        s.offset = offsets[dir]
        offsets[dir] = offsets[dir] + e.len
      end
      add_slot(et, range, s)
      entries[#entries + 1] = s
    end
  end
  return entries
end

-- Set_Prm user parameters, telegram bytes 7..15 (manual §5.1.2).
local function dissect_user_prm(tvb, tree)
  local t = tree:add(p_cdp, tvb, "CAN-DP/2 user parameters")
  local flags, diag = tvb(2, 1):uint(), tvb(4, 1):uint()
  t:add(F.reserved, tvb(0, 1))
  t:add(F.bitrate, tvb(1, 1))
  local ft = t:add(F.flags, tvb(2, 1))
  for _, b in ipairs(flag_bits) do ft:add(F["fl_" .. b[1]], tvb(2, 1)) end
  t:add(F.module_id, tvb(3, 1))
  local dt = t:add(F.diag_flags, tvb(4, 1))
  dt:add(F.can_diag, tvb(4, 1)); dt:add(F.rx_counter, tvb(4, 1)); dt:add(F.tx_counter, tvb(4, 1))
  t:add(F.reserved, tvb(5, 1))
  t:add(F.wakeup, tvb(6, 1))
  t:add(F.sync, tvb(7, 2))
  local rate = bitrates[tvb(1, 1):uint()] or "?"
  t:append_text(": CAN " .. rate .. ", ModuleID " .. tvb(3, 1):uint())
  return {
    candp2 = true, page_mode = has(flags, 0x01), can_diag = has(diag, 0x01),
    rx_counter = has(diag, 0x02),
    tx_counter = has(diag, 0x04), text = "CAN " .. rate,
  }
end

local function dissect_set_prm(tvb, tree, st)
  if tvb:len() < 7 then tree:add_proto_expert_info(E.dp_short); return "" end
  local ps = tree:add(F.prm_status, tvb(0, 1))
  for _, f in ipairs({ F.prm_lock, F.prm_unlock, F.prm_sync, F.prm_freeze, F.prm_wd_on }) do
    ps:add(f, tvb(0, 1))
  end
  tree:add(F.prm_wd1, tvb(1, 1)); tree:add(F.prm_wd2, tvb(2, 1))
  tree:add(F.prm_wd_ms, tvb(1, 2), 10 * tvb(1, 1):uint() * tvb(2, 1):uint()):set_generated()
  tree:add(F.prm_tsdr, tvb(3, 1))
  tree:add(F.prm_ident, tvb(4, 2))
  tree:add(F.prm_group, tvb(6, 1))
  local ident = tvb(4, 2):uint()
  local text = string.format("ident %04X", ident)
  if tvb:len() > 7 then tree:add(F.prm_user, tvb(7)) end
  if ident == 0x04A4 and tvb:len() == 16 then
    st.prm = dissect_user_prm(tvb(7), tree)
    text = text .. ", " .. st.prm.text
  else
    st.prm = nil
  end
  return text
end

local function dissect_diag(tvb, tree, st)
  if tvb:len() < 6 then tree:add_proto_expert_info(E.dp_short); return "" end
  local d1 = tree:add(F.diag1, tvb(0, 1))
  for _, b in ipairs(diag1_bits) do d1:add(F["d1_" .. b[1]], tvb(0, 1)) end
  local d2 = tree:add(F.diag2, tvb(1, 1))
  for _, b in ipairs(diag2_bits) do d2:add(F["d2_" .. b[1]], tvb(1, 1)) end
  tree:add(F.diag3, tvb(2, 1)); tree:add(F.diag_master, tvb(3, 1)); tree:add(F.diag_ident, tvb(4, 2))
  local names = {}
  for _, b in ipairs(diag1_bits) do
    if has(tvb(0, 1):uint(), b[3]) then names[#names + 1] = b[2] end
  end
  local text = #names > 0 and table.concat(names, " ") or "OK"
  if tvb:len() > 6 then tree:add(F.diag_ext, tvb(6)) end
  if tvb(4, 2):uint() ~= 0x04A4 or tvb:len() < 11 then return text end
  -- A CAN-DP/2 whose Set_Prm the capture did not see: its slots decode with default parameters.
  st.prm = st.prm or { candp2 = true, text = "" }
  -- manual table 3.4.5: bytes 8..10.
  local t = tree:add(p_cdp, tvb(8, 3), "CAN-DP/2 diagnosis bytes 8..10")
  local b8 = tvb(8, 1):uint()
  if b8 == 0x3D then
    t:add(F.diag_sap, tvb(8, 1)); t:add(F.prm_byte, tvb(9, 1)); t:add(F.prm_correct, tvb(10, 1))
    text = text .. string.format(", Prm fault: byte %d, correct %02X", tvb(9, 1):uint(),
      tvb(10, 1):uint())
  elseif b8 == 0x3E then
    t:add(F.diag_sap, tvb(8, 1)); t:add(F.cfg_slot, tvb(9, 1)); t:add(F.cfg_code, tvb(10, 1))
    text = text .. string.format(", Cfg fault: slot %d, %s", tvb(9, 1):uint(),
      cfg_codes[tvb(10, 1):uint()] or "code " .. tvb(10, 1):uint())
  elseif has(tvb(0, 1):uint(), 0x08) or st.prm.can_diag then
    t:add(F.bus_state, tvb(8, 1)); t:add(F.irq_lost, tvb(9, 1)); t:add(F.msg_lost, tvb(10, 1))
    text = text .. ", CAN " .. (bus_states[band(b8, 0xC0)] or "?")
  else
    t:append_text(": none")
  end
  return text
end

-- Output (request) or input (answer) bytes split into the station's slots.
local function dissect_image(tvb, tree, st, input)
  tree:add(input and F.inputs or F.outputs, tvb)
  if not st.slots then return hex(tvb) end
  local parts = {}
  for _, s in ipairs(st.slots) do
    if s.input == input and s.offset and s.offset + s.length <= tvb:len() then
      local r = tvb(s.offset, s.length)
      local t = tree:add(p_cdp, r, slot_text(s) .. ": " .. hex(r))
      t:add(F.slot, r, s.index):set_generated()
      if s.id then t:add(F.slot_id, r, s.id):set_generated() end
      t:add(F.slot_data, r)
      if s.id then parts[#parts + 1] = string.format(s.ext and "%08X:" or "%03X:", s.id) .. hex(r) end
    end
  end
  return #parts > 0 and table.concat(parts, " ") or hex(tvb)
end

local function dissect_dp(tvb, tree, ctx, st)
  local t = tree:add(p_dp, tvb)
  t:add(F.service, ctx.service):set_generated()
  t:add(F.response, not ctx.request):set_generated()
  if ctx.changed then t:add(F.changed, true):set_generated() end  -- present only when true
  local name = services[ctx.service] or "?"
  local text = ""
  if ctx.service == 61 and ctx.request then
    text = dissect_set_prm(tvb, t, st)
  elseif (ctx.service == 62 and ctx.request) or (ctx.service == 59 and not ctx.request) then
    local slots = dissect_cfg(tvb, t, st.prm)
    if st.prm then
      st.slots = slots
      local s = {}
      for _, x in ipairs(slots) do s[#s + 1] = slot_text(x) end
      text = table.concat(s, "; ")
    end
  elseif ctx.service == 60 and not ctx.request then
    text = dissect_diag(tvb, t, st)
  elseif ctx.service == 58 and ctx.request and tvb:len() >= 1 then
    t:add(F.gc_control, tvb(0, 1))
    if tvb:len() >= 2 then t:add(F.gc_group, tvb(1, 1)) end
  elseif ctx.service == S_DX and tvb:len() > 0 then
    text = dissect_image(tvb, t, st, not ctx.request)
  end
  t:append_text(": " .. name .. (ctx.request and ".req" or ".res"))
  return name .. (ctx.request and ".req" or ".res") .. (text ~= "" and " " .. text or "")
end

-------------------------------------------------------------------------------------- FDL
local function sum(tvb, from, to)
  local s = 0
  local raw = tvb:raw(from, to - from)
  for i = 1, #raw do s = s + raw:byte(i) end
  return s % 256
end

-- The context of a telegram on the first pass: its service, the station it concerns, and for
-- an answer the request it answers.
local function context(pinfo, t)
  local iface_f = f_interface()
  local iface = iface_f and iface_f.value or 0
  local ctx = { request = t.request }
  if t.sd == SD4 then ctx.service = S_TOKEN; return ctx end
  if t.request then
    if t.fn == 0x9 then ctx.service = S_FDL_STATUS
    elseif t.dsap then ctx.service = service_of_sap(t.dsap)
    else ctx.service = S_DX end
    ctx.station = t.da
    last_request[iface] = {
      service = ctx.service, station = t.da, master = t.sa, frame = pinfo.number,
    }
  else
    local req = last_request[iface]
    if t.sd == SC and req then
      ctx.service, ctx.station, ctx.request_in = req.service, req.station, req.frame
      ctx.src, ctx.dst = req.station, req.master  -- an SC names neither: its request does
    elseif t.ssap then
      ctx.service, ctx.station = service_of_sap(t.ssap), t.sa
    elseif req and req.station == t.sa then
      ctx.service, ctx.station = req.service, t.sa
    else
      ctx.service, ctx.station = S_DX, t.sa
    end
    if req and req.station == ctx.station then ctx.request_in = req.frame end
    last_request[iface] = nil
  end
  if ctx.station then ctx.state = station_state(iface, ctx.station) end
  if ctx.state and ctx.service == S_DX then
    -- dp.changed: the outputs (inputs) differ from the station's previous exchange.
    local data, key = t.du and t.du:raw() or "", t.request and "last_out" or "last_in"
    ctx.changed = ctx.state[key] ~= data
    ctx.state[key] = data
  end
  return ctx
end

-- The telegram's length from its start delimiter (and LE); nil and a reason when it has none.
local function frame_length(tvb, ft)
  local n, sd = tvb:len(), tvb(0, 1):uint()
  if sd == SC then return 1 end
  if sd == SD4 then return 3 end
  if sd == SD1 then return 6, 1 end
  if sd == SD3 then return 14, 1 end
  if sd ~= SD2 then
    ft:add_proto_expert_info(E.sd)
    return nil, string.format("not a telegram (first byte %02X)", sd)
  end
  if n < 4 then ft:add_proto_expert_info(E.short); return nil, "SD2 truncated" end
  local le = tvb(1, 1):uint()
  ft:add(F.le, tvb(1, 1)); ft:add(F.ler, tvb(2, 1))
  if le ~= tvb(2, 1):uint() or tvb(3, 1):uint() ~= SD2 or le < 3 then
    ft:add_proto_expert_info(E.le)
    return nil, "SD2 with a wrong LE/LEr"
  end
  return le + 6, 4
end

-- FC, address extensions, data unit, FCS and ED of an SD1/SD2/SD3 whose DA is at `at`; fills
-- `t` and returns the Info text for them.
local function dissect_body(tvb, ft, t, at, total)
  local info = ""
  local r_fc = tvb(at + 2, 1)
  local fc = r_fc:uint()
  t.request, t.fn = has(fc, 0x40), band(fc, 0x0F)
  local fct = ft:add(F.fc, r_fc)
  fct:add(F.fc_req, r_fc)
  if t.request then
    fct:add(F.fc_reqfn, r_fc)
    local fcb_fcv = t.fn == 0x3 or t.fn == 0x5 or t.fn == 0xC or t.fn == 0xD
    if t.fn ~= 0x9 then info = info .. " " .. (req_functions[t.fn] or "?") end
    if fcb_fcv then
      fct:add(F.fc_fcb, r_fc); fct:add(F.fc_fcv, r_fc)
      info = info .. string.format(" FCB=%d FCV=%d", band(shr(fc, 5), 1), band(shr(fc, 4), 1))
    end
  else
    fct:add(F.fc_stype, r_fc); fct:add(F.fc_resfn, r_fc)
    info = info .. " " .. (res_functions[t.fn] or "?")
  end
  local pos, fcs_at = at + 3, total - 2
  for i, which in ipairs({ "dsap", "ssap" }) do
    if has(tvb(at + i - 1, 1):uint(), 0x80) and pos < fcs_at then
      local sap = tvb(pos, 1):uint()
      if has(sap, 0xC0) then ft:add_proto_expert_info(E.sap) end
      ft:add(F[which], tvb(pos, 1))
      t[which] = band(sap, 0x3F)
      pos = pos + 1
    end
  end
  if t.dsap or t.ssap then info = info .. " [" .. (t.ssap or "-") .. "→" .. (t.dsap or "-") .. "]" end
  t.du = pos < fcs_at and tvb(pos, fcs_at - pos) or nil
  if t.du then ft:add(F.du, t.du) end
  local fcs, want = tvb(fcs_at, 1):uint(), sum(tvb, at, fcs_at)
  local fi = ft:add(F.fcs, tvb(fcs_at, 1))
  fi:add(F.fcs_ok, tvb(fcs_at, 1), fcs == want):set_generated()
  if fcs ~= want then
    fi:add_proto_expert_info(E.fcs, string.format("FCS wrong: %02X, expected %02X", fcs, want))
    t.fcs_bad = true
  end
  ft:add(F.ed, tvb(total - 1, 1))
  if tvb(total - 1, 1):uint() ~= ED then ft:add_proto_expert_info(E.ed) end
  return info
end

-- The DP layer of a telegram, with the station's state as the frame found it on the first pass.
local function dissect_service(tvb, pinfo, tree, ft, t)
  if not pinfo.visited then
    local ctx = context(pinfo, t)
    -- The station's parameters as this frame found them: what later passes dissect it with.
    if ctx.state then ctx.before = { prm = ctx.state.prm, slots = ctx.state.slots } end
    frames[pinfo.number] = ctx
  end
  local ctx = frames[pinfo.number]
  if ctx.request_in then ft:add(F.request_in, ctx.request_in):set_generated() end
  if ctx.src then pinfo.cols.src, pinfo.cols.dst = tostring(ctx.src), tostring(ctx.dst) end
  if not ctx.service or ctx.service == S_TOKEN then return nil end
  pinfo.cols.protocol = "DP"
  local work = { prm = ctx.before and ctx.before.prm, slots = ctx.before and ctx.before.slots }
  local text = dissect_dp(t.du or tvb(0, 0), tree, ctx, work)
  if not pinfo.visited and ctx.state then
    local changed = ctx.state.slots ~= work.slots
    ctx.state.prm, ctx.state.slots = work.prm, work.slots
    if changed then index_can_ids() end
  end
  return text
end

function p_fdl.dissector(tvb, pinfo, tree)
  local n = tvb:len()
  pinfo.cols.protocol = "FDL"
  local ft = tree:add(p_fdl, tvb())
  if n == 0 then ft:add_proto_expert_info(E.short); return 0 end
  local sd = tvb(0, 1):uint()
  ft:add(F.sd, tvb(0, 1))
  local total, at = frame_length(tvb, ft)
  if not total then pinfo.cols.info = at; return n end
  ft:add(F.kind, tvb(0, 1), sd_names[sd]):set_generated()
  if n < total then
    ft:add_proto_expert_info(E.short)
    pinfo.cols.info = sd_names[sd] .. " truncated"
    return n
  end
  if n > total then ft:add_tvb_expert_info(E.trailing, tvb(total)) end
  local t = { sd = sd, request = sd ~= SC }
  local info = sd_names[sd]
  if sd ~= SC then
    at = at or 1
    local r_da, r_sa = tvb(at, 1), tvb(at + 1, 1)
    t.da, t.sa = band(r_da:uint(), 0x7F), band(r_sa:uint(), 0x7F)
    ft:add(F.da, r_da)
    if sd ~= SD4 then ft:add(F.da_ext, r_da) end
    ft:add(F.sa, r_sa)
    if sd ~= SD4 then ft:add(F.sa_ext, r_sa) end
    pinfo.cols.src, pinfo.cols.dst = tostring(t.sa), tostring(t.da)
    info = info .. " " .. t.sa .. "→" .. t.da
    if sd ~= SD4 then info = info .. dissect_body(tvb, ft, t, at, total) end
  end
  local text = dissect_service(tvb, pinfo, tree, ft, t)
  if text then
    info = (sd == SC and "SC" or info) .. " " .. text
  elseif sd == SD4 then
    info = info .. " token"
  end
  pinfo.cols.info = (t.fcs_bad and "[FCS wrong] " or "") .. info
  return total
end

-- CAN frames on identifiers of CAN-DP/2 slots seen in a Chk_Cfg: which gateway slot sends or
-- receives them (manual §5.2). A heuristic of Wireshark's CAN dissector; frames on other
-- identifiers are left to it.
local function can_heuristic(tvb, pinfo, tree)
  local users
  if not pinfo.visited then
    local id, xtd = f_can_id(), f_can_xtd()
    if id then users = can_ids[((xtd and xtd.value) and "x" or "s") .. id.value] end
    can_frames[pinfo.number] = users or false
  else
    users = can_frames[pinfo.number]
  end
  if not users then return false end
  local parts = {}
  for _, u in ipairs(users) do
    local sl = u.slot
    local what = "station " .. u.station .. " slot" .. sl.index .. " " .. sl.kind
    local t = tree:add(p_cdp, tvb(), "CAN-DP/2 station " .. u.station .. " " .. slot_text(sl))
    t:add(F.can_station, tvb(), u.station):set_generated()
    t:add(F.slot, tvb(), sl.index):set_generated()
    t:add(F.slot_kind, tvb(), sl.kind):set_generated()
    if tvb:len() > 0 then t:add(F.can_data, tvb()) end
    parts[#parts + 1] = what
  end
  pinfo.cols.info:append((tvb:len() > 0 and ": " .. hex(tvb()) or "") .. " (" ..
    table.concat(parts, ", ") .. ")")
  return true
end
p_cdp:register_heuristic("can", can_heuristic)

-- The emulator's own records, exported PDUs for the "candp2" dissector: operator notes.
function p_cdp.dissector(tvb, pinfo, tree)
  pinfo.cols.protocol = "candp2"
  local t = tree:add(p_cdp, tvb(), "candp2 note")
  local text = tvb():string(ENC_UTF_8)
  t:add(F.note, tvb())
  pinfo.cols.info = "Note: " .. text
  return tvb:len()
end
