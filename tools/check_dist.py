"""Check the built wheel and sdist: the files a user needs are in them, and the version is one."""

from __future__ import annotations

import sys
import tarfile
import zipfile
from pathlib import Path

WHEEL_MUST_HOLD = (
    "robostar/__init__.py",
    "robostar/__main__.py",
    "robostar/py.typed",
    "robostar/cli/app.py",
    # the OPC UA face's companion nodesets and their licence (package data)
    "robostar/serve/faces/opcua/nodesets/Opc.Ua.Di.NodeSet2.xml",
    "robostar/serve/faces/opcua/nodesets/Opc.Ua.IA.NodeSet2.xml",
    "robostar/serve/faces/opcua/nodesets/Opc.Ua.Robotics.NodeSet2.xml",
    "robostar/serve/faces/opcua/nodesets/LICENSE",
)
SDIST_MUST_HOLD = (
    "pyproject.toml",
    "README.md",
    "LICENSE",
    "CHANGELOG.md",
    "src/robostar/py.typed",
    "src/robostar/serve/faces/opcua/nodesets/LICENSE",
)


def main(folder: str) -> int:
    dist = Path(folder)
    wheels = sorted(dist.glob("robostar-*.whl"))
    sdists = sorted(dist.glob("robostar-*.tar.gz"))
    if len(wheels) != 1 or len(sdists) != 1:
        print(f"expected one wheel and one sdist in {dist}, found {wheels + sdists}")
        return 1
    names = set(zipfile.ZipFile(wheels[0]).namelist())
    missing = [name for name in WHEEL_MUST_HOLD if name not in names]
    if not any(name.endswith(".dist-info/licenses/LICENSE") for name in names):
        missing.append("*.dist-info/licenses/LICENSE")
    with tarfile.open(sdists[0]) as sdist:
        root = sdist.getnames()[0].split("/")[0]
        members = {name.removeprefix(root + "/") for name in sdist.getnames()}
    missing += [f"sdist:{name}" for name in SDIST_MUST_HOLD if name not in members]
    if missing:
        print(f"missing from the distributions: {', '.join(missing)}")
        return 1
    print(f"ok: {wheels[0].name} ({len(names)} files), {sdists[0].name}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "dist"))
