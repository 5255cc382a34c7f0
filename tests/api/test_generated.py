"""The clients' methods as tools see them: real signatures and docstrings for help(),
inspect, ``unittest.mock.create_autospec`` and mypy, generated from the plans and never stale."""

from __future__ import annotations

import asyncio
import inspect
import subprocess
import sys
import typing
from pathlib import Path
from unittest import mock

import pytest

from robostar import AsyncClient, Client
from robostar.client.binding import operations
from robostar.client.surface import Operations

ROOT = Path(__file__).resolve().parents[2]
NAMES = [name for name, _ in operations(Operations)]


def test_the_generated_files_are_up_to_date() -> None:
    done = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "generate_faces.py"), "--check"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, f"run `make generate`: {done.stderr}"


def test_every_operation_is_a_method_of_both_clients() -> None:
    assert len(NAMES) >= 50
    for name in NAMES:
        assert inspect.isfunction(getattr(Client, name)), name
        assert inspect.iscoroutinefunction(getattr(AsyncClient, name)), name


@pytest.mark.parametrize("name", NAMES)
def test_signature_and_docstring_match_the_plan(name: str) -> None:
    plan = getattr(Operations, name)
    want = inspect.signature(plan, eval_str=True)
    result = typing.get_type_hints(plan)["return"]
    assert typing.get_origin(result) is not None  # Plan[X]: Generator[Effect, Any, X]
    value = typing.get_args(result)[-1]
    for cls in (Client, AsyncClient):
        method = getattr(cls, name)
        got = inspect.signature(method)
        assert list(got.parameters.values()) == list(want.parameters.values()), cls
        returned = type(None) if got.return_annotation is None else got.return_annotation
        assert returned == value, cls
        assert inspect.getdoc(method) == inspect.getdoc(plan)
    # On an instance the signature is the call a user makes: no self.
    bound = inspect.signature(getattr(Client.__new__(Client), name))
    assert "self" not in bound.parameters


def test_help_shows_the_call_and_the_docstring() -> None:
    text = pydoc_text(Client.move)
    assert "move(self, channel: int, target: collections.abc.Sequence[float]" in text
    assert "BC: move to ``target``" in text
    assert "-> None" in text


def pydoc_text(obj: object) -> str:
    import pydoc

    return pydoc.render_doc(obj, renderer=pydoc.plaintext)


def test_an_autospec_mock_takes_the_real_calls_only() -> None:
    robot = mock.create_autospec(Client, instance=True)
    robot.position.return_value = "a position"
    assert robot.position(1, kind="angle") == "a position"
    robot.position.assert_called_once_with(1, kind="angle")
    with pytest.raises(TypeError):
        robot.position(1, "angle", "extra")
    with pytest.raises(TypeError):
        robot.status(1)
    with pytest.raises(AttributeError):
        robot.no_such_method  # noqa: B018


def test_an_async_autospec_mock_is_awaitable() -> None:
    robot = mock.create_autospec(AsyncClient, instance=True)
    robot.speed.return_value = 40

    async def main() -> int:
        value: int = await robot.speed(1)
        return value

    assert asyncio.run(main()) == 40


SNIPPET = """
from robostar import AsyncClient, Client
from robostar.commands.status import ReadStatus

def sync_user(robot: Client) -> None:
    reveal_type(robot.status())
    reveal_type(robot.position(1, "xy"))
    reveal_type(robot.download_job(1, "RS.JOB"))
    reveal_type(robot.execute(ReadStatus()))
    robot.move(1, [1.0, 2.0], wait=True)

async def async_user(robot: AsyncClient) -> None:
    reveal_type(robot.status)
    reveal_type(await robot.read_global_float(3))
    reveal_type(await robot.servo(1, True))
"""


def test_mypy_strict_sees_results_and_coroutines(tmp_path: Path) -> None:
    script = tmp_path / "user.py"
    script.write_text(SNIPPET)
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(script)],
        capture_output=True,
        text=True,
        check=False,
        cwd=tmp_path,
    )
    lines = [line for line in done.stdout.splitlines() if "Revealed type" in line]
    revealed = [line.split("Revealed type is ", 1)[1].strip('"') for line in lines]
    channel = "robostar.types.ChannelStatus"
    assert revealed == [
        f"tuple[{channel}, {channel}, {channel}]",
        "robostar.types.Position",
        "robostar.types.JobFile",
        f"tuple[{channel}, {channel}, {channel}]",
        f"def () -> typing.Coroutine[Any, Any, tuple[{channel}, {channel}, {channel}]]",
        "float",
        "int",
    ], done.stdout
    errors = [line for line in done.stdout.splitlines() if ": error:" in line]
    assert errors == [], done.stdout


SAMPLES = {
    "Command[R]": "ReadStatus()",
    "Point | Sequence[float]": "Point((1.0, 2.0))",
    "PointFile | Mapping[int, Point]": "{1: Point((1.0, 2.0))}",
    "Sequence[float]": "[1.0, 2.0]",
    "Sequence[str]": '["MAIN", "EOP"]',
    "bool": "True",
    "float": "1.5",
    "int": "1",
    "int | None": "1",
    "str | FileName": '"RS.JOB"',
    "str | os.PathLike[str]": '"backup"',
}
"""A value of each annotation a required parameter has (a new one fails the test below)."""


def _every_call() -> list[str]:
    import ast

    tree = ast.parse((ROOT / "src" / "robostar" / "client" / "surface.py").read_text())
    calls = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.ClassDef) and node.name == "Operations"):
            continue
        for plan in node.body:
            if not isinstance(plan, ast.FunctionDef) or plan.name not in NAMES:
                continue
            args = plan.args
            required = args.args[1 : len(args.args) - len(args.defaults)]
            values = [SAMPLES[ast.unparse(a.annotation)] for a in required if a.annotation]
            for arg, default in zip(args.kwonlyargs, args.kw_defaults, strict=True):
                if default is None and arg.annotation is not None:
                    values.append(f"{arg.arg}={SAMPLES[ast.unparse(arg.annotation)]}")
            calls.append(f"{plan.name}({', '.join(values)})")
    return calls


def test_a_snippet_calling_every_method_of_both_clients_passes_mypy_strict(
    tmp_path: Path,
) -> None:
    calls = _every_call()
    assert len(calls) == len(NAMES)
    lines = [
        "from robostar import AsyncClient, Client, Point",
        "from robostar.commands.status import ReadStatus",
        "",
        "def sync_user(robot: Client) -> None:",
        *(f"    robot.{call}" for call in calls),
        "",
        "async def async_user(robot: AsyncClient) -> None:",
        *(f"    await robot.{call}" for call in calls),
    ]
    script = tmp_path / "every.py"
    script.write_text("\n".join(lines) + "\n")
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(script)],
        capture_output=True,
        text=True,
        check=False,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stdout
