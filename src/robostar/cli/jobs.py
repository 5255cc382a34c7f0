"""``robostar job``: the running job's name and step, and select/start/stop/reset/mode."""

from __future__ import annotations

import click
from rich.text import Text

from robostar.cli.control import done
from robostar.cli.options import ControllerFile, common_options, get_session
from robostar.cli.session import ConsoleSession, pass_session
from robostar.commands.control import ResetJob, StartJob, StopJob
from robostar.commands.job import ReadJobName, ReadJobStep, SelectJob, SetJobMode
from robostar.commands.status import ReadStatus
from robostar.types import JobMode

__all__ = ["job"]


@click.group(invoke_without_command=True)
@common_options(channel=True)
@click.pass_context
def job(ctx: click.Context) -> None:
    """Show the channel's job (name, step, running); subcommands select and run jobs.

    \b
    Example:
      robostar job
      robostar job select DEMO.JOB && robostar job start
    """
    if ctx.invoked_subcommand is not None:
        return
    session = get_session(ctx)
    channel = session.channel
    name = session.send(ReadJobName(channel))
    step = session.send(ReadJobStep(channel))
    running = session.send(ReadStatus())[channel - 1].running
    shown = str(name) if name is not None else None
    session.out.result(
        {"channel": channel, "job": shown, "step": step, "running": running},
        Text(
            f"Channel {channel} job: {shown or '(none selected)'}, step {step}, "
            f"{'running' if running else 'not running'}"
        ),
    )


@job.command()
@click.argument("name", type=ControllerFile("JOB"))
@common_options(channel=True)
@pass_session
def select(session: ConsoleSession, name: str) -> None:
    """Select the JOB file NAME as the channel's job (DC); homing must be done.

    \b
    Example:
      robostar job select DEMO.JOB
    """
    session.send(SelectJob(session.channel, name))
    done(
        session, f"Channel {session.channel} job is now {name}.", channel=session.channel, job=name
    )


@job.command()
@common_options(channel=True)
@pass_session
def start(session: ConsoleSession) -> None:
    """Start the selected job (CC). The robot moves as the job says.

    \b
    Example:
      robostar job start
    """
    session.announce(f"Starting the job on channel {session.channel}: the robot will move.")
    session.send(StartJob(session.channel))
    done(
        session, f"Job started on channel {session.channel}.", channel=session.channel, running=True
    )


@job.command()
@common_options(channel=True)
@pass_session
def stop(session: ConsoleSession) -> None:
    """Stop the running job (CD).

    \b
    Example:
      robostar job stop
    """
    session.send(StopJob(session.channel))
    done(
        session,
        f"Job stopped on channel {session.channel}.",
        channel=session.channel,
        running=False,
    )


@job.command()
@common_options(channel=True)
@pass_session
def reset(session: ConsoleSession) -> None:
    """Set the job back to its first step (CE); the servo must be off.

    \b
    Example:
      robostar servo off && robostar job reset
    """
    session.send(ResetJob(session.channel))
    done(
        session,
        f"Job reset to its first step on channel {session.channel}.",
        channel=session.channel,
        step=0,
    )


@job.command()
@click.argument("mode", type=click.Choice(["auto", "step"], case_sensitive=False))
@common_options(channel=True)
@pass_session
def mode(session: ConsoleSession, mode: str) -> None:
    """Run the job in auto mode (all steps) or step mode (one step per start) (EA).

    The job must not be running.

    \b
    Example:
      robostar job mode step
    """
    value = JobMode.STEP if mode.lower() == "step" else JobMode.AUTO
    session.send(SetJobMode(session.channel, value))
    done(
        session,
        f"Channel {session.channel} job mode: {value.name.lower()}.",
        channel=session.channel,
        mode=value.name.lower(),
    )
