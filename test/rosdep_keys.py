"""Do package.xml's rosdep keys resolve? Checked against ros/rosdistro, the database `rosdep` reads.

    python -m test.rosdep_keys --rosdistro DIR [--distro kilted] [--write]   # against a rosdistro copy
    python -m test.rosdep_keys                                            # against the stored snapshot

A key resolves when rosdistro's ``rosdep/base.yaml`` or ``rosdep/python.yaml`` gives it a rule for Debian
and Ubuntu (a system package or a ``pip`` one), or when it names a ROS package released in the distro
(``<distro>/distribution.yaml``: a repository's ``release.packages``, or the repository itself when it
lists none), as ``rosdep install`` resolves them. ``DIR`` is a rosdistro checkout or its bare git
directory (read at HEAD with ``git show``). ``--write`` stores what the keys resolved to, with the
rosdistro commit, in ``test/rosdep_snapshot.yaml``; without ``--rosdistro`` the keys are checked against
that snapshot (``test/test_rosdep_keys.py`` does, offline). Exit 1 names every key that does not resolve.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parent.parent
SNAPSHOT = Path(__file__).resolve().parent / "rosdep_snapshot.yaml"
PLATFORMS = ("debian", "ubuntu")
"""Platforms every key must resolve on: the ROS 2 Tier 1 Linux (ubuntu) and Debian."""
RULE_FILES = ("rosdep/base.yaml", "rosdep/python.yaml")


def package_keys(path: Path = ROOT / "package.xml") -> list[str]:
    """Every dependency key of package.xml (any *depend tag), in order, each once."""
    keys: list[str] = []
    for element in ET.parse(path).getroot():
        if element.tag.endswith("depend") and element.text and element.text.strip() not in keys:
            keys.append(element.text.strip())
    return keys


class Rosdistro:
    """A rosdistro copy: a checkout (files) or a git directory (read at HEAD)."""

    def __init__(self, path: Path) -> None:
        """Open ``path``; ValueError when it is neither a rosdistro checkout nor its git directory."""
        self.path = path
        self.git = not (path / "rosdep" / "base.yaml").is_file()
        if self.git and self._git("rev-parse", "HEAD") is None:
            raise ValueError(f"{path} is neither a rosdistro checkout nor its git directory")

    def _git(self, *args: str) -> str | None:
        """Output of git with --git-dir (or -C for a checkout); None when git fails."""
        where = ["--git-dir", str(self.path)] if self.git else ["-C", str(self.path)]
        done = subprocess.run(["git", *where, *args], capture_output=True, text=True)
        return done.stdout if done.returncode == 0 else None

    @property
    def commit(self) -> str:
        """The commit read (HEAD), or 'unknown' for a checkout outside git."""
        return (self._git("rev-parse", "HEAD") or "unknown").strip()

    def read(self, name: str) -> Any:
        """Parsed YAML file ``name`` (e.g. rosdep/base.yaml)."""
        text = self._git("show", f"HEAD:{name}") if self.git else (self.path / name).read_text()
        if text is None:
            raise ValueError(f"{self.path} has no {name}")
        return yaml.safe_load(text)


def resolve(keys: list[str], rosdistro: Rosdistro, distro: str) -> dict[str, dict[str, Any]]:
    """{key: where it resolves: {source, and per platform the rule}} for the keys that resolve."""
    found: dict[str, dict[str, Any]] = {}
    for name in RULE_FILES:
        rules = rosdistro.read(name)
        for key in keys:
            rule = rules.get(key)
            if key not in found and isinstance(rule, dict) and all(p in rule for p in PLATFORMS):
                found[key] = {"source": name, **{p: rule[p] for p in PLATFORMS}}
    released: set[str] = set()
    for repo, entry in (rosdistro.read(f"{distro}/distribution.yaml").get("repositories") or {}).items():
        release = entry.get("release") if isinstance(entry, dict) else None
        if isinstance(release, dict):
            released.update(release.get("packages") or [repo])
    for key in keys:
        if key not in found and key in released:
            found[key] = {"source": f"{distro}/distribution.yaml"}
    return found


def check(keys: list[str], snapshot: dict[str, Any]) -> list[str]:
    """Keys that the snapshot does not resolve."""
    return [k for k in keys if k not in (snapshot.get("keys") or {})]


def main(argv: list[str] | None = None) -> int:
    """Resolve package.xml's keys against a rosdistro copy (and store them), or check them against the
    snapshot; exit 1 naming the keys that do not resolve."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rosdistro", type=Path, help="rosdistro checkout or git directory")
    parser.add_argument("--distro", default="kilted", help="ROS 2 distro of its packages (default kilted)")
    parser.add_argument("--write", action="store_true", help=f"store the resolution in {SNAPSHOT.name}")
    args = parser.parse_args(argv)
    keys = package_keys()
    if args.rosdistro is None:
        snapshot = yaml.safe_load(SNAPSHOT.read_text())
        source = f"the snapshot of ros/rosdistro {snapshot['rosdistro_commit']} ({SNAPSHOT.name})"
    else:
        try:
            rosdistro = Rosdistro(args.rosdistro)
            snapshot = {
                "rosdistro_commit": rosdistro.commit,
                "distro": args.distro,
                "platforms": list(PLATFORMS),
                "keys": resolve(keys, rosdistro, args.distro),
            }
        except ValueError as err:
            print(f"rosdep_keys: {err}", file=sys.stderr)
            return 2
        source = f"ros/rosdistro {snapshot['rosdistro_commit']}"
        if args.write:
            header = (
                "# package.xml's rosdep keys as ros/rosdistro resolves them: written by\n"
                "# `python -m test.rosdep_keys --rosdistro DIR --write`;\n"
                "# checked by test/test_rosdep_keys.py.\n"
            )
            SNAPSHOT.write_text(header + yaml.safe_dump(snapshot, sort_keys=False))
    missing = check(keys, snapshot)
    if missing:
        print(f"rosdep_keys: no rule in {source} for: {', '.join(missing)}", file=sys.stderr)
        return 1
    print(f"all {len(keys)} keys of package.xml resolve in {source}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
