"""candp2: the CAN-DP/2 emulator as a test instrument (docs/python.md).

    import candp2

    with candp2.Daemon("plant.json") as daemon:
        gw, can0 = daemon.gateway(3), daemon.bus("can0")
        gw.wait_until(lambda g: g.state == "Data_Exch")
        gw.outputs[0:5] = bytes.fromhex("51 00 00 00 00")
        can0.expect(0x201, bytes.fromhex("51 00 00 00 00"))

A thin, typed client of candp2d's public faces: Modbus/TCP (the PLC process image, the status
block, the fault registers), HTTP (slots, parameters, drives) and socketcand (the CAN buses).
It knows no register number: it reads them from `candp2d --print-modbus-map --json`.
"""

from .binary import example, find_binary, find_example, find_tool
from .bus import Bus, Recorder, candump_line, frame_text
from .connection import Connection, connect
from .daemon import Daemon, HostStalls, running_daemons
from .drive import Drive, DriveState
from .errors import (Candp2Error, ConfigError, DaemonError, FrameNotSeen, ModbusError,
                     NoLine, UnexpectedFrame, WaitTimeout)
from .gateway import CfgFault, Counters, Diagnosis, Gateway, Led, Leds, PrmFault, Slot
from .line import BusCycle, Line, LineFault, LineStation, LiveList
from .registers import RegisterMap
from .replay import ReplayResult, ReplayStep, replay
from .slave import DiagBlock, FieldImage, Slave, SlaveDiagnosis, SlaveFaults
from .station import Image, Station
from .timing import BusLoad, BusTiming, CanFaultInForce, IdentifierTiming, NodeCounters, NotTimed

__version__ = "0.1.0"

__all__ = [
    "Bus", "BusCycle", "BusLoad", "BusTiming", "CanFaultInForce", "Candp2Error", "CfgFault",
    "ConfigError", "Connection", "Counters", "Daemon", "DaemonError", "DiagBlock", "Diagnosis",
    "Drive", "DriveState", "FieldImage", "FrameNotSeen", "Gateway", "HostStalls",
    "IdentifierTiming", "Image", "Led", "Leds", "Line", "LineFault", "LineStation", "LiveList",
    "ModbusError", "NoLine", "NodeCounters", "NotTimed", "PrmFault", "Recorder", "RegisterMap",
    "ReplayResult", "ReplayStep", "Slave", "SlaveDiagnosis", "SlaveFaults", "Slot", "Station",
    "UnexpectedFrame", "WaitTimeout", "candump_line", "connect", "example", "find_binary",
    "find_example", "find_tool", "frame_text", "replay", "running_daemons",
]
