"""Every code block on every page (the README and docs/) is checked: TOML, JSON and YAML parse, Python compiles,
C compiles against the generated header it uses, and each `mlca-verify` or `mlca-sim` command line is one the
command's parser accepts. Command blocks with their output are run by tests/test_docs.py, whole specs in the
guides by tests/test_guides.py: this test catches what would otherwise go stale unseen (a renamed flag, a
struct member, a key)."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import tomllib
from pathlib import Path

import pytest
import yaml

from mlca_verify import cli
from sim_check import cli as sim_cli
from tests.conftest import ROOT

FENCE = re.compile(r"^```([a-z0-9]+)\n(.*?)^```", re.DOTALL | re.MULTILINE)
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
BLOCKS = [
    pytest.param(lang, body, id=f"{page.relative_to(ROOT)}:{text[: m.start()].count(chr(10)) + 1}:{lang}")
    for page in PAGES
    for text in [page.read_text(encoding="utf-8")]
    for m in FENCE.finditer(text)
    for lang, body in [(m.group(1), m.group(2))]
    if lang in ("toml", "json", "yaml", "python", "c", "sh", "console")
]
HEADERS = [ROOT / "generated" / "c", ROOT / "docs" / "tutorial" / "generated" / "c"]


def test_the_pages_hold_code_of_every_kind() -> None:
    kinds = {p.values[0] for p in BLOCKS}
    assert {"toml", "json", "yaml", "python", "c", "sh", "console"} <= kinds and len(BLOCKS) >= 50


@pytest.mark.parametrize(("lang", "body"), BLOCKS)
def test_each_block_is_what_its_language_accepts(lang: str, body: str, tmp_path: Path) -> None:
    if lang == "toml":
        tomllib.loads(body)
    elif lang == "json":
        json.loads(body)
    elif lang == "yaml":
        yaml.safe_load(body)
    elif lang == "python":
        compile(body, "<block>", "exec")
    elif lang == "c":
        _compiles(body, tmp_path)
    else:
        _commands_parse(body, tmp_path)


def _compiles(body: str, tmp_path: Path) -> None:
    """The block's includes on top, its statements in a function; the header of the machine it names when it
    includes none. The integrator's own functions (read_sensors, actuate) are declared for it."""
    lines = body.splitlines()
    includes = [line for line in lines if line.startswith("#include")]
    if not includes:
        prefix = re.search(r"\b(\w+)_ctx_t\b", body)
        assert prefix is not None
        includes = [f'#include "{prefix.group(1)}_fsm.h"']
    statements = "\n".join(line for line in lines if not line.startswith("#include"))
    source = tmp_path / "block.c"
    wrapper = ["void read_sensors(void *in);", "void actuate(long command);", "void example(void);"]
    text = "\n".join([*includes, *wrapper, "void example(void)", "{", statements, "}", ""])
    source.write_text(text, encoding="utf-8")
    flags = ["-std=c99", "-Wall", "-Werror", "-Wno-unused-variable", "-fsyntax-only", *[f"-I{h}" for h in HEADERS]]
    ran = subprocess.run(["gcc", *flags, str(source)], capture_output=True, text=True, check=False)
    assert ran.returncode == 0, ran.stderr


def _commands_parse(body: str, tmp_path: Path) -> None:
    """Each command line: `mlca-verify` and `mlca-sim` parsed by their own parsers, `bash scripts/...` a script
    of the repository, a compiler's run from the repository's root with its output in a folder of its own."""
    seen = 0
    for line in body.splitlines():
        words = shlex.split(line.removeprefix("$ "), comments=True)
        if not words:
            continue
        tool = Path(words[0]).name
        if tool == "mlca-verify":
            cli._parser().parse_args(words[1:])
        elif tool == "mlca-sim":
            sim_cli._parser().parse_args(words[1:])
        elif words[0] == "bash":
            assert (ROOT / words[1]).is_file(), words[1]
        elif tool in ("gcc", "arm-none-eabi-gcc"):
            out = words.index("-o") + 1
            words[out] = str(tmp_path / Path(words[out]).name)
            ran = subprocess.run(words, capture_output=True, text=True, check=False, cwd=ROOT)
            assert ran.returncode == 0, ran.stderr
        else:
            continue
        seen += 1
    assert seen, body
