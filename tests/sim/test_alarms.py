"""The alarm log: current alarms for AB, the history for FH with the work timer."""

from __future__ import annotations

from robostar.sim.alarms import ALL_CHANNELS, AlarmCode, AlarmLog, alarm_text
from robostar.types import Alarm


def test_manual_codes_keep_the_manual_texts():
    assert alarm_text(1153) == "T/P Emergency"
    assert alarm_text(1104) == "Servo Not Redy"
    assert alarm_text(AlarmCode.HOST_EMERGENCY) == "Host Emergency"
    assert alarm_text(4321) == "Alarm 4321"
    assert all(len(alarm_text(code)) <= 20 for code in AlarmCode)


def test_current_alarms_are_per_channel_and_cleared():
    log = AlarmLog()
    log.raise_alarm(AlarmCode.RUN_FAIL, 2, at=5.0, detail="CC no origin")
    assert log.on_channel(2) and not log.on_channel(1)
    log.raise_alarm(AlarmCode.HOST_EMERGENCY, ALL_CHANNELS, at=6.0)
    assert log.on_channel(1) and log.on_channel(3)
    assert log.alarms() == (Alarm(9002, "Run Fail"), Alarm(9001, "Host Emergency"))
    log.clear()
    assert log.alarms() == () and not log.on_channel(2)
    assert len(log.history) == 2


def test_the_same_alarm_is_listed_once_but_recorded_each_time():
    log = AlarmLog()
    for t in range(3):
        log.raise_alarm(AlarmCode.SOFT_LIMIT, 1, at=float(t))
    assert len(log.alarms()) == 1
    assert len(log.history) == 3


def test_current_list_keeps_the_last_ten():
    log = AlarmLog()
    for code in range(2000, 2012):
        log.raise_alarm(code, 1, at=0.0)
    assert [a.code for a in log.alarms()] == list(range(2002, 2012))


def test_history_records_page_by_ten_newest_first_with_the_work_timer():
    log = AlarmLog()
    for i in range(12):
        log.raise_alarm(3000 + i, 1, at=90061.0 + i, detail=f"detail {i}")
    records = log.records()
    assert len(records) == 12
    first = records[0]
    assert (first.page, first.index, first.code) == (1, 1, 3011)
    assert (first.day, first.hours, first.minutes, first.seconds) == (1, 1, 1, 12)
    assert (records[10].page, records[10].index) == (2, 1)
    assert first.detail == "detail 11"


def test_history_is_capped():
    log = AlarmLog()
    for i in range(150):
        log.raise_alarm(AlarmCode.RUN_FAIL, 1, at=float(i))
    assert len(log.records()) == 100
    assert log.records()[-1].page == 10
