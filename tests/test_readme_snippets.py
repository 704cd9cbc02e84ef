#!/usr/bin/env python3
"""The README's snippets, pasted as a new user would after the README's two commands.

Every fenced sh, cmake and python block of README.md has a marker on the line before it that
says what this test does with it:

  <!-- snippet: run -->             sh: run with `sh -e` from the checkout root; python: run with
                                    python3 from the checkout root, the build tree's package on
                                    PYTHONPATH (the one `pip install ./python` builds)
  <!-- snippet: file PATH -->       the block is the file PATH (from the checkout root) verbatim
  <!-- snippet: ci -->              every command in it is a line of .ci/run, which runs it
  <!-- snippet: not run: REASON --> nothing (the reason says why, and what covers it instead)

A block without a marker fails the test, so a new snippet is never left out silently. Each
snippet runs in a fresh shell with HOME and TMPDIR in a scratch folder: `$HOME/.local` is a
scratch install prefix, and mktemp's folders are scratch too; the variables a user would not
have set (PKG_CONFIG_PATH, CMAKE_PREFIX_PATH, pgem_DIR, PYTHONPATH) are unset. The test fails
when a snippet fails or when the checkout (outside build/) gains, loses or changes a file.
A snippet naming ../shared/datasets is skipped, saying so, where that folder is absent.
Under `sh -e` a failing command stops its snippet, but not one inside an `a && b` list: a run
snippet holds one command per line, and one with && or || fails.

Usage: test_readme_snippets.py SOURCE_DIR BUILD_DIR
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

FENCED = ("sh", "cmake", "python")
TIMEOUT = 180  # seconds per snippet
DATASETS = "../shared/datasets"
UNSET = ("PKG_CONFIG_PATH", "CMAKE_PREFIX_PATH", "pgem_DIR", "PYTHONPATH")
IGNORED = {".git", "__pycache__"}  # plus build/, the build trees


@dataclass
class Snippet:
    line: int      # the line of README.md that opens the fence
    language: str  # sh, cmake or python
    marker: str    # the marker's text after "snippet:", "" when there is none
    text: str      # the block's lines, each ending in a newline


def snippets(readme: Path) -> list[Snippet]:
    """The fenced blocks in the languages this test knows, each with the marker before it."""
    found: list[Snippet] = []
    lines = readme.read_text().splitlines(keepends=True)
    index = 0
    while index < len(lines):
        fence = re.match(r"```(\w*)\s*$", lines[index])
        if not fence:
            index += 1
            continue
        end = index + 1
        while end < len(lines) and not lines[end].startswith("```"):
            end += 1
        if fence.group(1) in FENCED:
            previous = index - 1
            while previous >= 0 and not lines[previous].strip():
                previous -= 1
            marker = re.fullmatch(r"<!--\s*snippet:\s*(.*?)\s*-->",
                                  lines[previous].strip() if previous >= 0 else "")
            found.append(Snippet(index + 1, fence.group(1), marker.group(1) if marker else "",
                                 "".join(lines[index + 1:end])))
        index = end + 1
    return found


def checkout_state(source: Path) -> dict[str, tuple[int, int]]:
    """Every file of the checkout outside build/ (and .git, __pycache__): size and mtime."""
    state: dict[str, tuple[int, int]] = {}
    for folder, subfolders, files in os.walk(source):
        here = Path(folder)
        subfolders[:] = [name for name in subfolders
                         if name not in IGNORED and not (here == source and name == "build")]
        for name in files:
            path = here / name
            try:
                status = path.lstat()
            except OSError:
                continue
            state[str(path.relative_to(source))] = (status.st_size, status.st_mtime_ns)
    return state


def commands(text: str) -> list[str]:
    """A shell block's commands: its lines without comments and blank lines."""
    result = []
    for line in text.splitlines():
        command = re.sub(r"\s+#.*$", "", line).strip()
        if command and not command.startswith("#"):
            result.append(command)
    return result


def check_ci(snippet: Snippet, source: Path) -> str | None:
    """None when .ci/run runs each of the snippet's commands, else what is missing."""
    ci = {command for command in commands((source / ".ci/run").read_text())}
    missing = [command for command in commands(snippet.text) if command not in ci]
    return f".ci/run does not run: {'; '.join(missing)}" if missing else None


def check_file(snippet: Snippet, path: str, source: Path) -> str | None:
    """None when the block is the file verbatim."""
    try:
        text = (source / path).read_text()
    except OSError as error:
        return f"cannot read {path}: {error}"
    return None if text == snippet.text else f"the block is not {path} verbatim; update its copy"


def run(snippet: Snippet, source: Path, build: Path, scratch: Path) -> str | None:
    """Runs the snippet; None when it succeeded, else why it failed."""
    env = {name: value for name, value in os.environ.items() if name not in UNSET}
    env.update(HOME=str(scratch / "home"), TMPDIR=str(scratch / "tmp"))
    if snippet.language == "sh":
        lists = [line for line in commands(snippet.text) if "&&" in line or "||" in line]
        if lists:
            return f"one command per line (sh -e misses a failure inside a list): {lists[0]}"
        command = ["sh", "-e", "-c", snippet.text]
    elif snippet.language == "python":
        package = build / "python"
        if not (package / "pgem").is_dir():
            return skip(f"this build has no Python package ({package})")
        env["PYTHONPATH"] = str(package)
        env["MPLBACKEND"] = "Agg"
        command = [sys.executable, "-c", snippet.text]
    else:
        return f"a {snippet.language} block cannot be run; mark it `file PATH` or `not run: why`"
    try:
        result = subprocess.run(command, cwd=source, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        return f"still running after {TIMEOUT} s"
    sys.stdout.write(indent(result.stdout))
    return None if result.returncode == 0 else f"exit status {result.returncode}"


def skip(reason: str) -> None:
    """Says why a snippet is not run here (not a failure)."""
    print(f"   skipped: {reason}")


def indent(text: str) -> str:
    lines = text.splitlines()
    if len(lines) > 40:  # the head and the tail, where a failure says what went wrong
        lines = lines[:15] + [f"... ({len(lines) - 30} lines)"] + lines[-15:]
    return "".join(f"   | {line}\n" for line in lines)


def check(snippet: Snippet, source: Path, build: Path, scratch: Path) -> str | None:
    """What the snippet's marker asks; None when it holds, else why not."""
    marker = snippet.marker
    if not marker:
        return ("no marker: put <!-- snippet: run -->, <!-- snippet: file PATH -->, "
                "<!-- snippet: ci --> or <!-- snippet: not run: REASON --> on the line before it")
    if marker == "run":
        if DATASETS in snippet.text and not (source / DATASETS).is_dir():
            return skip(f"{DATASETS} is not there")
        return run(snippet, source, build, scratch)
    if marker == "ci":
        return check_ci(snippet, source)
    if marker.startswith("file "):
        return check_file(snippet, marker[len("file "):].strip(), source)
    if re.match(r"not run:\s*\S", marker):
        return None
    return f"unknown marker `snippet: {marker}`"


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    source, build = Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()
    found = snippets(source / "README.md")
    if not found:
        print("readme_snippets: README.md has no sh, cmake or python block")
        return 1
    before = checkout_state(source)
    scratch = Path(tempfile.mkdtemp(prefix="pgem-readme-"))
    failures = []
    try:
        for name in ("home", "tmp"):
            (scratch / name).mkdir()
        for snippet in found:
            print(f"== README.md:{snippet.line}: {snippet.language}, {snippet.marker or 'no marker'}",
                  flush=True)
            failure = check(snippet, source, build, scratch)
            if failure is not None:
                failures.append(f"README.md:{snippet.line} ({snippet.language}): {failure}")
                print(f"   FAILED: {failure}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    after = checkout_state(source)
    for path in sorted(set(before) | set(after)):
        if path not in before:
            failures.append(f"the snippets left {path} in the checkout")
        elif path not in after:
            failures.append(f"the snippets removed {path} from the checkout")
        elif before[path] != after[path]:
            failures.append(f"the snippets changed {path} in the checkout")
    for failure in failures:
        print(f"readme_snippets: {failure}")
    ran = sum(1 for snippet in found if snippet.marker == "run")
    print(f"readme_snippets: {len(found)} blocks, {ran} run, {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
