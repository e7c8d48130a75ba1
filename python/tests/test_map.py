"""The register map comes from the daemon, and nowhere else."""

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from candp2 import Candp2Error, ConfigError, RegisterMap

from plants import MANUAL_514, PLC_LINE

PACKAGE = Path(__file__).resolve().parent.parent / "candp2"


def write(tmp_path: Path, config: object) -> Path:
    path = tmp_path / "plant.json"
    path.write_text(json.dumps(config))
    return path


def test_map_of_a_configuration(candp2_binary: str, tmp_path: Path) -> None:
    m = RegisterMap.from_binary(candp2_binary, write(tmp_path, MANUAL_514))
    (gw,) = m.gateways
    assert (gw.name, gw.dp_address) == ("gw5", 5)
    assert set(m.first_gateway_units) < set(gw.units)
    slot_in, slot_out = gw.slots
    assert (slot_in.plc, slot_in.address, slot_in.length) == ("I", 172, 6)
    assert (slot_in.first_register, slot_in.last_register) == (172 // 2, 177 // 2)
    assert slot_out.table == m.outputs.table and slot_in.table == m.inputs.table
    # The status fields tile the block.
    covered = sorted(r for f in m.fields.values() for r in range(f.register,
                                                                 f.register + f.registers))
    assert covered == list(range(m.status.first, m.status.first + m.status.count))
    assert m.value_name("dp_state", 2) == "Data_Exch"
    assert m.forced_states["real"] == 0 and "bus-off" in m.forced_states
    assert set(m.commands) >= {"power_cycle", "reparameterize", "master_stop", "master_resume"}


def test_map_of_generic_slaves(candp2_binary: str, tmp_path: Path) -> None:
    m = RegisterMap.from_binary(candp2_binary, write(tmp_path, PLC_LINE))
    io1, io2 = m.slaves
    assert (io1.name, io1.dp_address, io1.units, io1.field_unit) == ("io1", 8, (8,), 108)
    assert (io2.input_bytes, io2.output_bytes, io2.remote) == (2, 2, False)
    assert m.slave(9) == io2 and m.slave(3) is None
    assert set(m.slave_faults) == {"on_bus", "prm_fault", "cfg_fault", "alarm_length",
                                   "alarm_bytes"}
    assert 2 * m.alarm_bytes.count == 62  # device-related bytes of a diagnosis alarm
    # The whole diagnosis: its length, then up to 244 bytes (IEC 61158-6-3), in one read.
    assert m.diagnosis_bytes.first == m.diagnosis_length_register + 1
    assert 2 * m.diagnosis_bytes.count == 244
    assert m.diagnosis_bytes.count + 1 <= m.limits["read_registers"]
    assert (m.field_inputs, m.field_outputs) == ("holding_registers", "input_registers")
    assert m.without_configuration().slaves == ()


def test_decode_status_combines_words(candp2_binary: str) -> None:
    m = RegisterMap.from_binary(candp2_binary)
    words = list(range(m.status.count))
    status = m.decode_status(words)
    tx = m.fields["tx_frames"]
    offset = tx.register - m.status.first
    assert status["tx_frames"] == (offset << 16) | (offset + 1)
    diag = m.fields["diag"]
    assert status["diag"] == tuple(range(diag.register - m.status.first,
                                         diag.register - m.status.first + diag.registers))


def test_no_register_number_in_the_package(candp2_binary: str) -> None:
    """Every register number of the status block, control and fault registers appears in the
    daemon's JSON only: no integer literal of the package's source equals one of them."""
    m = RegisterMap.from_binary(candp2_binary)
    numbers = {r for f in m.fields.values() for r in range(f.register, f.register + f.registers)}
    numbers |= {m.control_register, m.forced_state_register, m.drop_rx_register,
                m.status.first + m.status.count, m.diagnosis_length_register,
                m.diagnosis_bytes.first, m.diagnosis_bytes.first + m.diagnosis_bytes.count - 1}
    numbers |= set(m.slave_faults.values())
    numbers |= {m.alarm_bytes.first + m.alarm_bytes.count - 1}
    found = []
    for source in PACKAGE.glob("*.py"):
        for node in ast.walk(ast.parse(source.read_text())):
            if isinstance(node, ast.Constant) and type(node.value) is int \
                    and node.value in numbers:
                found.append("%s:%d: %d" % (source.name, node.lineno, node.value))
    assert not found, "register numbers written in the package: %s" % found


def test_refused_configuration_names_the_json_path(candp2_binary: str, tmp_path: Path) -> None:
    bad = json.loads(json.dumps(MANUAL_514))
    bad["gateways"][0]["slots"][1]["length"] = "six"
    with pytest.raises(ConfigError) as info:
        RegisterMap.from_binary(candp2_binary, write(tmp_path, bad))
    assert info.value.path == "$.gateways[0].slots[1].length"
    assert "expected a number from 1 to 64" in info.value.message
    assert info.value.returncode == 2


def test_a_document_of_another_version_is_refused(candp2_binary: str) -> None:
    out = subprocess.run([candp2_binary, "--print-modbus-map", "--json"], capture_output=True,
                         text=True, check=True).stdout
    document = json.loads(out)
    document["version"] = 99
    with pytest.raises(Candp2Error, match="do not match"):
        RegisterMap(document)


def test_shell_assignments(candp2_binary: str, tmp_path: Path) -> None:
    """python3 -m candp2 map --shell: what the QEMU guest scripts source."""
    out = tmp_path / "registers.sh"
    r = subprocess.run([sys.executable, "-m", "candp2", "map", "--shell", "--binary",
                        candp2_binary, "--config", str(write(tmp_path, MANUAL_514)),
                        "--output", str(out)], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(PACKAGE.parent)))
    assert r.returncode == 0, r.stderr
    m = RegisterMap.from_binary(candp2_binary, tmp_path / "plant.json")
    values = dict(line.split("=", 1) for line in out.read_text().splitlines()
                  if not line.startswith("#"))
    assert values["STATUS_DP_STATE"] == str(m.fields["dp_state"].register)
    assert values["STATUS_DIAG"] == str(m.fields["diag"].register)
    assert values["FAULT_DROP_RX"] == str(m.drop_rx_register)
    assert values["GW5_SLOT1_FIRST"] == str(172 // 2) and values["GW5_SLOT1_LAST"] == str(177 // 2)
    assert values["SLAVE_ON_BUS"] == str(m.slave_faults["on_bus"])
    assert values["DIAGNOSIS_LENGTH"] == str(m.diagnosis_length_register)
    # sh reads it.
    r = subprocess.run(["sh", "-c", ". %s && echo $((STATUS_DIAG + 8))" % out],
                       capture_output=True, text=True)
    assert r.stdout.strip() == str(m.fields["diag"].register + 8)
