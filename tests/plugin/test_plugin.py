"""The pytest plugin as an integrator uses it: a test file of theirs, run by pytest, with
nothing but the fixtures."""

from __future__ import annotations

import pytest

USER_TESTS = '''
import asyncio

import pytest

from robostar import OutcomeUnknownError, AlarmRaisedError


def pick_and_place(robot, pick, place):
    """The user's routine: home, move to pick, close the gripper, move to place, open."""
    robot.home(1, wait=True)
    robot.move(1, pick, wait=True)
    robot.set_output(0, 3, True)
    robot.move(1, place, wait=True)
    robot.set_output(0, 3, False)
    return robot.position(1, "angle")


def test_the_routine_ends_at_the_place_with_the_gripper_open(n1_client, n1_sim):
    end = pick_and_place(n1_client, (10.0, 20.0, 0.0, 0.0), (40.0, -15.0, 5.0, 0.0))
    assert end.axes[:2] == pytest.approx((40.0, -15.0), abs=0.01)
    assert not n1_client.outputs(0).contacts[3]
    assert n1_sim.executions["BC"] == 2


@pytest.mark.n1_sim(channels=1, robot="xy", axes=2)
def test_a_marker_configures_the_controller(n1_client):
    info = n1_client.info()
    assert info.max_channels == 1 and info.channels[0].axes_in_use == (1, 2)


@pytest.mark.n1_sim(dialect="capacity")
def test_a_dialect_through_the_marker(n1_client):
    n1_client.upload_job(1, "PP.JOB", ["MAIN", "EOP"])
    assert n1_client.download_job(1, "PP.JOB").announced == 2000


def test_a_lost_answer_to_a_move_is_an_unknown_outcome(n1_client, n1_sim):
    n1_client.home(1, wait=True)
    n1_sim.fault("drop:to_host@0*8")  # the move's answer never arrives
    with pytest.raises(OutcomeUnknownError):
        n1_client.move(1, (5.0, 0.0, 0.0, 0.0))
    n1_sim.heal()
    assert n1_sim.executions["BC"] == 1  # it did run: the routine must not send it again


def test_an_alarm_while_waiting(n1_client, n1_sim):
    n1_client.home(1, wait=True)
    n1_client.move(1, (110.0, 0.0, 0.0, 0.0))
    n1_sim.raise_alarm(1153, 1)
    with pytest.raises(AlarmRaisedError):
        n1_client.wait_stopped(1, timeout=5)


def test_the_async_client(n1_async_client, n1_sim):
    async def main():
        status = await n1_async_client.status()
        await n1_async_client.write_global_int(4, 99)
        return status, await n1_async_client.read_global_int(4)

    status, value = asyncio.run(main())
    assert status[0].ready and value == 99
    assert n1_sim.model.ints[4] == 99
'''


def test_an_integrators_tests_run_with_the_fixtures_alone(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_user=USER_TESTS)
    result = pytester.runpytest_subprocess("-q", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=6)


def test_the_marker_is_registered(pytester: pytest.Pytester) -> None:
    result = pytester.runpytest_subprocess("--markers")
    result.stdout.fnmatch_lines(["*n1_sim(**options)*"])


def test_a_bad_marker_option_is_a_clear_error(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_bad="""
import pytest

@pytest.mark.n1_sim(wheels=4)
def test_it(n1_client):
    pass
"""
    )
    result = pytester.runpytest_subprocess("-q")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*unknown key(s) wheels*"])
