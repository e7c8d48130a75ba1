#!/usr/bin/python3
"""Writes spec10.bin: the capture in docs/profibus.md "A real master's first telegrams" (an
open-source class 1 master at address 2
parameterizing CAN-DP/2 slave 3, §5.1.4 slots), the slave's responses as candp2's FDL front end
sends them (tests/profibus/fdl_slave_test.cpp), and some line noise: garbage bytes, a token, a
telegram with a wrong FCS. Run: /usr/bin/python3 tests/sniff/make_capture.py tests/sniff/spec10.bin
"""
import sys


def sd1(da, sa, fc):
    body = bytes([da, sa, fc])
    return bytes([0x10]) + body + bytes([sum(body) & 0xFF, 0x16])


def sd2(da, sa, fc, du, dsap=None, ssap=None):
    body = bytes([da | (0x80 if dsap is not None else 0), sa | (0x80 if ssap is not None else 0), fc])
    if dsap is not None:
        body += bytes([dsap])
    if ssap is not None:
        body += bytes([ssap])
    body += bytes(du)
    return bytes([0x68, len(body), len(body), 0x68]) + body + bytes([sum(body) & 0xFF, 0x16])


H = bytes.fromhex
SC = H("E5")
out = b""
out += H("00 FF 55")                                   # noise before the first telegram
out += H("10 03 02 49 4E 16") + sd1(2, 3, 0x00)        # FDL_Status
out += H("68 05 05 68 83 82 6D 3C 3E EC 16")           # Slave_Diag (FCB=1 FCV=0)
out += sd2(2, 3, 0x08, H("02 05 00 FF 04 A4 05 04 00 00 00"), 62, 60)
out += H("68 15 15 68 83 82 5D 3D 3E 88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF 2C 16") + SC
out += H("68 0F 0F 68 83 82 7D 3E 3E 43 85 02 89 B8 83 85 03 09 B8 D5 16") + SC
out += H("68 05 05 68 83 82 5D 3C 3E DC 16")
out += sd2(2, 3, 0x08, H("00 0C 00 02 04 A4 05 04 00 00 00"), 62, 60)
out += H("DC 03 02")                                   # a token (ignored by slaves)
out += H("68 09 09 68 03 02 7D 11 22 33 44 55 66 E7 16") + sd2(2, 3, 0x08, H("00" * 6))
out += H("68 09 09 68 03 02 5D 11 22 33 44 55 66 C8 16")  # FCS wrong: no answer, master retries
out += H("68 09 09 68 03 02 5D 11 22 33 44 55 66 C7 16") + sd2(2, 3, 0x0A, H("0A 0B 0C 0D 0E 0F"))
out += sd2(3, 2, 0x7D, b"", 59, 62)                      # Get_Cfg
out += sd2(2, 3, 0x08, H("43 85 02 89 B8 83 85 03 09 B8"), 62, 59)
out += sd1(4, 2, 0x49)                                   # FDL_Status to an absent station 4
out += H("10 03 02")                                     # truncated at the end of the file
open(sys.argv[1], "wb").write(out)
