"""Line faults on cue (docs/faults.md "Line faults"): a PLC program must ride out a bad PROFIBUS
line. On a line in time, candp2 makes the fault happen when the test says so and counts what a
PROFIBUS analyser counts (docs/profibus.md "Line statistics"), exactly.

The plant is config/line-1500k.json as candp2 ships it: a 1.5 Mbit/s line with retry limit 1, a
CAN-DP/2 gateway at DP address 3 and a generic slave at 4 (the example GSD gsd/CDP2C0A.GSD), the
master parameterizing a lost station again after 100 ms.

candp2.find_example() finds the file in the source checkout (config/line-1500k.json) or beside an
installed candp2d (/usr/share/candp2/examples/).
"""

from typing import Callable

from candp2 import Daemon, find_example


def test_faults_on_cue_and_what_an_analyser_counts(candp2d: Callable[..., Daemon],
                                                   candp2_binary: str) -> None:
    daemon = candp2d(find_example("line-1500k.json", candp2_binary))
    gw, io = daemon.gateway(3), daemon.slave(4)
    gw.wait_until(lambda g: g.state == "Data_Exch" and g.master_state == "Data_Exch")
    io.wait_until(lambda s: s.state == "Data_Exch" and s.master_state == "Data_Exch")
    line = daemon.line  # on an ideal line (no master.baud) this says so: candp2.NoLine
    assert line.live_list.ok == (3, 4)
    start = line.station(3)

    # Five corrupt answers of the gateway, one in every two requests: each is an illegal
    # telegram, the master repeats the request once and gets a good answer. It never drops out.
    # A station's wait_until() reads its counters again until the predicate holds: the fifth
    # illegal answer is on the line before the repeat it causes, so wait for both (a status read
    # between the two would see five illegals and four repeats).
    line.inject(3, "corrupt", count=5, every=2)
    start.wait_until(lambda s: s.illegals == start.illegals + 5
                     and s.repeats == start.repeats + 5)
    s = daemon.line.station(3)
    assert (s.illegals, s.lost, s.syncs) == (start.illegals + 5, start.lost, start.syncs)
    assert s.repeats_max == 1 and s.live == "ok"

    # The generic slave falls silent for two requests: its Data_Exchange and the one repeat go
    # unanswered, it drops out of data exchange, and after retry_ms the master parameterizes it
    # again (one more Set_Prm) and it is back.
    before = line.station(4)
    line.inject(4, "silent", count=2)
    before.wait_until(lambda s: s.lost == before.lost + 1)
    before.wait_until(lambda s: s.syncs == before.syncs + 1 and s.live == "ok")
    after = daemon.line.station(4)
    assert after.repeats == before.repeats + 1 and after.illegals == before.illegals
    io.wait_until(lambda s: s.state == "Data_Exch" and s.master_state == "Data_Exch")
