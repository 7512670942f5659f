"""Finds and runs the shell and Python examples of README.md and docs/*.md (docs/testing.md,
"The documentation's examples run").

Every fenced block tagged ``sh``, ``bash``, ``shell``, ``console`` or ``python`` is an example.
The blocks of one page run in page order in one fresh directory, which holds a copy of
examples/, a link ``build`` to the build tree and a link ``tests`` to the test data; ``formfactor`` is on PATH and the Python module
on PYTHONPATH. Shell blocks run under ``bash -e -o pipefail``; in ``console`` blocks only the
lines after ``$ `` are run (the rest is the output shown). The Python blocks of a page share one
namespace. An HTML comment on the line(s) just before a block changes what runs:

    <!-- test: skip REASON -->          not run (REASON is required: say why)
    <!-- test: slow -->                 run only by the slow test (ctest label `slow`)
    <!-- test: setup                    run these lines first, then the block
    LINES -->
    <!-- test: instead                  run these lines instead of the block (a scaled-down
    LINES -->                           variant of an expensive example)

A failure names the page and the line of the command that failed.
"""

import dataclasses
import os
import pathlib
import re
import shutil
import subprocess
import traceback

SHELL_LANGS = {"sh", "bash", "shell", "console"}
PYTHON_LANGS = {"python", "py"}
MARKER = re.compile(r"<!--\s*test:\s*(\w+)(.*?)-->", re.S)


class DocExampleError(Exception):
    """An example that failed, or a marker that cannot be read: the message names FILE:LINE."""


@dataclasses.dataclass
class Block:
    path: str  # relative to the source tree, for messages
    line: int  # 1-based line of the block's first code line
    lang: str
    code: str
    marker: str = ""  # skip, slow, setup, instead or ""
    marker_line: int = 0  # first line of the marker's lines (setup/instead)
    marker_text: str = ""  # the reason (skip) or the lines (setup/instead)

    @property
    def where(self):
        return "%s:%d" % (self.path, self.line)


def doc_pages(source_dir):
    """README.md and docs/*.md, in a fixed order."""
    source_dir = pathlib.Path(source_dir)
    pages = [source_dir / "README.md"] + sorted((source_dir / "docs").glob("*.md"))
    return [p for p in pages if p.is_file()]


def parse_blocks(text, path):
    """The fenced code blocks of a markdown page, each with the marker just before it."""
    lines = text.split("\n")
    blocks = []
    i = 0
    while i < len(lines):
        m = re.match(r"^(\s*)(`{3,}|~{3,})\s*([\w+-]*)", lines[i])
        if not m:
            i += 1
            continue
        indent, fence, lang = m.group(1), m.group(2), m.group(3).lower()
        start = i
        j = i + 1
        while j < len(lines) and not re.match(r"^\s*" + re.escape(fence) + r"\s*$", lines[j]):
            j += 1
        if j == len(lines):
            raise DocExampleError("%s:%d: code block never closed (no %s line)"
                                  % (path, start + 1, fence))
        code = "\n".join(l[len(indent):] if l.startswith(indent) else l
                         for l in lines[start + 1:j]) + "\n"
        block = Block(path, start + 2, lang, code)
        _attach_marker(block, lines, start, path)
        blocks.append(block)
        i = j + 1
    return blocks


def _attach_marker(block, lines, fence_index, path):
    """Reads a `<!-- test: ... -->` comment ending on the line before the fence (blank lines
    between are allowed)."""
    k = fence_index - 1
    while k >= 0 and not lines[k].strip():
        k -= 1
    if k < 0 or not lines[k].rstrip().endswith("-->"):
        return
    end = k
    while k >= 0 and "<!--" not in lines[k]:
        k -= 1
    if k < 0:
        return
    comment = "\n".join(lines[k:end + 1])
    comment = comment[comment.index("<!--"):]
    m = MARKER.fullmatch(comment.strip())
    if not m:
        if re.match(r"<!--\s*test\b", comment):
            raise DocExampleError("%s:%d: cannot read this test marker (use skip REASON, slow, "
                                  "setup or instead; docs/testing.md)" % (path, k + 1))
        return
    kind, rest = m.group(1), m.group(2)
    if kind not in ("skip", "slow", "setup", "instead"):
        raise DocExampleError("%s:%d: unknown test marker '%s' (use skip REASON, slow, setup or "
                              "instead; docs/testing.md)" % (path, k + 1, kind))
    if kind == "skip" and not rest.strip():
        raise DocExampleError("%s:%d: 'test: skip' needs a reason" % (path, k + 1))
    if kind in ("setup", "instead"):
        first, _, remainder = rest.partition("\n")
        body, block.marker_line = (rest, k + 1) if first.strip() else (remainder, k + 2)
        if not body.strip():
            raise DocExampleError("%s:%d: 'test: %s' needs the lines to run" % (path, k + 1, kind))
        block.marker_text = body.rstrip() + "\n"
    else:
        block.marker_text = rest.strip()
    block.marker = kind


def console_commands(code):
    """The commands of a console block: the lines after `$ `, with their continuation lines
    (ending in a backslash); every other line becomes blank, so that line numbers hold."""
    out = []
    in_command = False
    for line in code.split("\n"):
        if line.startswith("$ "):
            out.append(line[2:])
            in_command = line.rstrip().endswith("\\")
        elif in_command:
            out.append(line)
            in_command = line.rstrip().endswith("\\")
        else:
            out.append("")
    return "\n".join(out)


def prepare_dir(work, source_dir, build_dir):
    """A fresh page directory: examples/ copied, build/ and tests/ (its data files) linked."""
    work = pathlib.Path(work)
    work.mkdir(parents=True, exist_ok=True)
    examples = pathlib.Path(source_dir) / "examples"
    if examples.is_dir():
        shutil.copytree(examples, work / "examples")
    if pathlib.Path(build_dir).is_dir():
        (work / "build").symlink_to(pathlib.Path(build_dir).resolve(), target_is_directory=True)
    tests = pathlib.Path(source_dir) / "tests"
    if tests.is_dir():
        (work / "tests").symlink_to(tests.resolve(), target_is_directory=True)
    return work


def example_env(build_dir):
    env = dict(os.environ)
    build_dir = pathlib.Path(build_dir).resolve()
    env["PATH"] = str(build_dir / "bin") + os.pathsep + env.get("PATH", "")
    env["PYTHONPATH"] = str(build_dir / "python") + (
        os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env["MPLBACKEND"] = "Agg"
    return env


def run_shell(code, first_line, path, work, env, timeout):
    """Runs shell lines; `first_line` is the page line of the first one."""
    script = ("trap 'echo \"%s:$LINENO: this command exited $?\" >&2' ERR\n" % path
              + "\n" * (first_line - 2) + code)
    p = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", script], cwd=work, env=env,
                       capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0:
        where = re.findall(re.escape(path) + r":\d+: this command exited \d+", p.stderr)
        head = where[-1] if where else "%s:%d: exited %d" % (path, first_line, p.returncode)
        stderr = re.sub(re.escape(path) + r":\d+: this command exited \d+\n?", "", p.stderr)
        raise DocExampleError("%s\n--- stderr (last lines):\n%s\n--- stdout (last lines):\n%s"
                              % (head, _tail(stderr), _tail(p.stdout)))
    return p


def run_python(code, first_line, path, work, namespace):
    """Runs Python lines in `namespace` with cwd = work; tracebacks carry page lines."""
    source = "\n" * (first_line - 1) + code
    old = os.getcwd()
    os.chdir(work)
    try:
        exec(compile(source, path, "exec"), namespace)
    except Exception as e:  # noqa: BLE001 -- every failure is reported with its page line
        tb = traceback.extract_tb(e.__traceback__)
        lines = [f.lineno for f in tb if f.filename == path]
        line = lines[-1] if lines else first_line
        raise DocExampleError("%s:%d: %s: %s\n%s" % (path, line, type(e).__name__, e,
                                                     _tail(traceback.format_exc()))) from None
    finally:
        os.chdir(old)


def run_page(page, source_dir, build_dir, work, slow=False, timeout=600):
    """Runs every example of one page in order; returns the number of blocks run."""
    source_dir = pathlib.Path(source_dir)
    path = str(pathlib.Path(page).resolve().relative_to(source_dir.resolve()))
    blocks = parse_blocks(pathlib.Path(page).read_text(), path)
    work = prepare_dir(work, source_dir, build_dir)
    env = example_env(build_dir)
    namespace = {"__name__": "__doc_example__"}
    ran = 0
    saved_path = os.environ.get("PATH", "")
    os.environ["PATH"] = env["PATH"]  # for Python examples that call the CLI
    try:
        for b in blocks:
            if b.lang not in SHELL_LANGS | PYTHON_LANGS or b.marker == "skip":
                continue
            if b.marker == "slow" and not slow:
                continue
            steps = []
            if b.marker == "setup":
                steps.append((b.marker_text, b.marker_line))
            if b.marker == "instead":
                steps.append((b.marker_text, b.marker_line))
            else:
                code = console_commands(b.code) if b.lang == "console" else b.code
                steps.append((code, b.line))
            for code, line in steps:
                if b.lang in SHELL_LANGS:
                    run_shell(code, line, path, work, env, timeout)
                else:
                    run_python(code, line, path, work, namespace)
            ran += 1
    finally:
        os.environ["PATH"] = saved_path
    return ran


def _tail(text, n=25):
    lines = text.rstrip("\n").split("\n")
    return "\n".join(lines[-n:])
