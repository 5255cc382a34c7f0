"""``robostar demo``: a guided tour of the whole tool on a simulator of its own.

It never touches --port: a newcomer's ROBOSTAR_PORT may name a real robot. Each step shows the
command that does the same from a terminal, then what it did.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import click
from rich.console import Group, RenderableType
from rich.rule import Rule
from rich.text import Text

from robostar.cli.inout import port_json
from robostar.cli.options import Finite, common_options
from robostar.cli.reading import (
    alarm_table,
    info_view,
    position_json,
    position_view,
    status_json,
    status_table,
)
from robostar.cli.render import jsonable, lamps_table
from robostar.cli.session import ConsoleSession, pass_session
from robostar.errors import ControllerError
from robostar.types import Point, PositionKind

__all__ = ["TOUR_JOB", "TOUR_POINTS", "demo"]

CHANNEL = 1
TOUR_JOB = (
    "MAIN",
    "JMOV P1",
    "OUT 0,1,1",
    "WAIT IN 0,2,1",
    "LMOV P2",
    "JMOV P3",
    "OUT 0,1,0",
    "EOP",
)
"""The job the tour uploads: it waits for input 0.2, which the tour switches on like a sensor."""
TOUR_POINTS = {
    1: Point((30.0, 60.0, 50.0, 0.0)),
    2: Point((0.0, 60.0, 50.0, 0.0)),
    3: Point((-30.0, 90.0, 100.0, 45.0)),
}
_WAIT_STEP = TOUR_JOB.index("WAIT IN 0,2,1") + 1


@dataclass
class _Tour:
    """What the steps share: the client, the simulator behind it, and the record for --json."""

    client: Any
    controller: Any
    session: ConsoleSession
    pause: float
    steps: list[dict[str, Any]] = field(default_factory=list)

    def step(self, title: str, command: str, text: str, run: Callable[[], RenderableType]) -> None:
        out = self.session.out
        number = len(self.steps) + 1
        if not out.json:
            out.console.print(Rule(Text(f"{number}. {title}", style="bold cyan"), align="left"))
            out.console.print(Text(text))
            out.console.print(Text(f"$ {command}", style="bold"))
        record: dict[str, Any] = {"step": number, "title": title, "command": command}
        self.steps.append(record)
        shown = run()
        if not out.json:
            out.console.print(shown)
        record["ok"] = True
        time.sleep(self.pause)

    def position(self) -> RenderableType:
        pos = self.client.position(CHANNEL, "xy")
        self.steps[-1]["position"] = position_json(CHANNEL, pos)
        return position_view(CHANNEL, pos)


def _job_run(tour: _Tour) -> RenderableType:
    client = tour.client
    lines: list[RenderableType] = []
    client.select_job(CHANNEL, "TOUR.JOB")
    client.start_job(CHANNEL)
    seen_step = 0
    sensor_on = False
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        status = client.status()[CHANNEL - 1]
        step = client.job_step(CHANNEL)
        if step > seen_step and step <= len(TOUR_JOB):
            seen_step = step
            line = Text(f"  step {step}: {TOUR_JOB[step - 1]}")
            lines.append(line)
            if not tour.session.out.json:
                tour.session.out.console.print(line)
        if step == _WAIT_STEP and status.running and not sensor_on:
            note = Text(
                "  the job set output 0.1 and waits for input 0.2: the tour switches that "
                "sensor on",
                style="yellow",
            )
            lines.append(note)
            if not tour.session.out.json:
                tour.session.out.console.print(note)
            waiting = lamps_table([("out 0", client.outputs(0).contacts)])
            lines.append(waiting)
            if not tour.session.out.json:
                tour.session.out.console.print(waiting)
            tour.controller.model.set_input(0, 2, True)
            sensor_on = True
        if not status.running and step != 0 and sensor_on:
            break
        time.sleep(0.05)
    outputs = client.outputs(0)
    tour.steps[-1]["outputs"] = port_json("out", outputs)
    return Group(
        Text("The job ran to its end.", style="green"), lamps_table([("out 0", outputs.contacts)])
    )


def _alarms(tour: _Tour) -> RenderableType:
    client = tour.client
    parts: list[RenderableType] = []
    try:
        client.move(CHANNEL, (200.0, 0.0, 50.0, 0.0))
    except ControllerError as error:
        parts.append(Text(f"Refused, as it should be: {error.reason or error}", style="yellow"))
        parts.append(Text("(on the command line this ends with exit code 3)", style="dim"))
        tour.steps[-1]["refused"] = error.reason
    client.emergency_stop()
    current = client.alarms()
    tour.steps[-1]["alarms"] = jsonable(current)
    parts.append(Text("After `robostar estop`:"))
    parts.append(alarm_table(current))
    client.reset_alarms()
    parts.append(Text("After `robostar reset`:"))
    parts.append(alarm_table(client.alarms()))
    return Group(*parts)


def _io(tour: _Tour) -> RenderableType:
    client = tour.client
    client.set_output(0, 5, True)
    tour.controller.model.set_input(0, 7, True)
    inputs, outputs = client.inputs(0), client.outputs(0)
    tour.steps[-1]["inputs"] = port_json("in", inputs)
    tour.steps[-1]["outputs"] = port_json("out", outputs)
    return lamps_table([("in 0", inputs.contacts), ("out 0", outputs.contacts)])


def _jog(tour: _Tour, seconds: float) -> RenderableType:
    tour.client.set_speed(CHANNEL, 100)
    with tour.client.jog(CHANNEL, 1, "+"):
        time.sleep(seconds)
    tour.client.wait_stopped(CHANNEL, 30)
    pos = tour.client.position(CHANNEL, PositionKind.ANGLE)
    tour.steps[-1]["position"] = position_json(CHANNEL, pos)
    return position_view(CHANNEL, pos)


def run_tour(tour: _Tour, jog_seconds: float) -> None:
    """Every step of the tour, in order."""
    client = tour.client
    tour.step(
        "Who is on the line",
        "robostar info",
        "AD tells the controller's name, version and what each channel drives.",
        lambda: info_view(client.info()),
    )

    def status() -> RenderableType:
        statuses = client.status()
        tour.steps[-1].update(status_json(statuses))
        return status_table(statuses)

    tour.step(
        "Status lamps",
        "robostar status",
        "AA reads six lamps per channel. A fresh controller: servo off, no origin.",
        status,
    )

    def servo() -> RenderableType:
        client.servo(CHANNEL, True)
        return Text("Servo on.", style="green")

    tour.step(
        "Servo on",
        "robostar servo on",
        "DB turns the servo on; it answers twice (at once, and when it is done).",
        servo,
    )

    def home() -> RenderableType:
        client.home(CHANNEL, wait=True)
        return tour.position()

    tour.step("Home", "robostar home", "BA returns to the origin; motions need it first.", home)

    def move() -> RenderableType:
        client.move(CHANNEL, (20.0, 45.0, 30.0, 0.0), wait=True)
        client.move_by(CHANNEL, (-20.0, 15.0, 0.0, 0.0), coords="xy", motion="linear", wait=True)
        return tour.position()

    tour.step(
        "Move",
        "robostar move 20 45 30 0 && robostar move --by --xy --linear -20 15 0 0",
        "BC moves to joint angles; BD moves by an amount, here in a straight line in XY.",
        move,
    )
    tour.step(
        "Jog",
        "robostar jog --axis 1 --direction + --for 0.5 --speed 100",
        "BE starts a jog, BF keeps it alive every 200 ms, BG stops it. Plain `robostar "
        "jog` is a full-screen pad that jogs while you hold a key.",
        lambda: _jog(tour, jog_seconds),
    )

    def upload() -> RenderableType:
        client.upload_points(CHANNEL, "TOUR.PNT", TOUR_POINTS)
        client.upload_job(CHANNEL, "TOUR.JOB", TOUR_JOB)
        files = client.list_files(CHANNEL)
        tour.steps[-1]["files"] = jsonable(files)
        names = ", ".join(f.name for f in files)
        return Group(
            Text("\n".join(TOUR_JOB), style="dim"),
            Text(f"Uploaded and verified; channel {CHANNEL} holds: {names}"),
        )

    tour.step(
        "Upload a job",
        "robostar files put tour.job --name TOUR.JOB",
        "FB uploads a file line by line; the client reads it back to verify it.",
        upload,
    )
    tour.step(
        "Run the job",
        "robostar job select TOUR.JOB && robostar job start",
        "DC selects the job, CC starts it; ED tells the step it is at.",
        lambda: _job_run(tour),
    )
    tour.step(
        "I/O",
        "robostar io set 0 5 on && robostar io in 0",
        "GC switches an output; GA and GB read 16 contacts per port.",
        lambda: _io(tour),
    )
    tour.step(
        "Alarms",
        "robostar estop && robostar alarms && robostar reset",
        "A move past the soft limits is refused with the controller's reason (KD); "
        "CF is the emergency stop, CG clears the alarms.",
        lambda: _alarms(tour),
    )


@click.command()
@click.option(
    "--speedup",
    type=Finite(1.0, 200.0),
    default=4.0,
    show_default=True,
    help="How much faster than real time the simulated robot moves.",
)
@click.option(
    "--pause",
    type=Finite(0.0, 10.0),
    default=0.8,
    show_default=True,
    metavar="SECONDS",
    help="Pause between steps, to read them.",
)
@click.option("--fast", is_flag=True, help="No pauses and a fast robot (for a quick check).")
@common_options()
@pass_session
def demo(session: ConsoleSession, speedup: float, pause: float, fast: bool) -> None:
    """A guided tour on a built-in simulator: status, servo, home, move, jog, a job, I/O, alarms.

    It runs on a simulator of its own and never uses --port. It takes well under a minute.

    \b
    Example:
      robostar --port sim:// demo
      robostar --port sim:// demo --fast
    """
    from robostar.client import Client
    from robostar.sim import SimConfig, VirtualController
    from robostar.transport.inproc import PeerTransport

    if fast:
        speedup, pause = max(speedup, 50.0), 0.0
    out = session.out
    out.extra["simulator"] = True
    out.extra["url"] = "sim://"  # its own simulator, whatever --port says
    port = session.settings.port
    if port is not None and port != "sim://":
        out.note(f"The demo runs on its own simulator; {port} is not touched.")
    controller = VirtualController(SimConfig(speedup=speedup))
    started = time.monotonic()
    with Client(PeerTransport(controller), trace=session.settings.trace) as client:
        tour = _Tour(client, controller, session, pause)
        if not out.json:
            out.console.print(
                Text("robostar demo: a tour of the console on a simulated N1 (SIMULATOR)", "bold")
            )
        run_tour(tour, 2.0 / speedup)
    took = time.monotonic() - started
    done_text = Text.assemble(
        ("That is the tour. ", "bold green"),
        f"It took {took:.0f} s. Next: `robostar --help`, `robostar monitor`, and "
        "`robostar --port tcp://HOST:PORT status` for a real controller.",
    )
    out.result(
        {"ok": True, "seconds": round(took, 2), "steps": tour.steps},
        lambda: Group(Rule(), done_text),
    )
