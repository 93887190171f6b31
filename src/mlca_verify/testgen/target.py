"""Processor in the loop: the suite's C program cross-compiled for a Cortex-M4 (binary64 in software), run on
QEMU's MPS2 AN386 board with semihosting, and its output compared line for line with the host's (back to back)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from mlca_verify.errors import ToolError
from mlca_verify.json_types import JsonObject
from mlca_verify.tools import C_FLAGS, run

SUPPORT = Path(__file__).resolve().parent / "cortex_m4"
CROSS = "arm-none-eabi-gcc"
QEMU = "qemu-system-arm"
BOARD = "mps2-an386"
ARM_FLAGS = ("-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=soft", "-O2", "-ffp-contract=off")
QEMU_TIMEOUT = 120


@dataclass
class TargetRun:
    """The target's output and how it compares with the host's."""

    board: str
    lines: list[str]
    host_lines: int
    first_difference: str  # "" when every line agrees
    exit_code: int
    seconds: float
    text_bytes: int

    @property
    def agrees(self) -> bool:
        return not self.first_difference and self.exit_code == 0 and len(self.lines) == self.host_lines

    def to_json(self) -> JsonObject:
        return {
            "board": self.board,
            "cpu": "cortex-m4",
            "lines": len(self.lines),
            "host_lines": self.host_lines,
            "agrees": self.agrees,
            "first_difference": self.first_difference,
            "exit_code": self.exit_code,
            "seconds": round(self.seconds, 3),
            "text_bytes": self.text_bytes,
        }


def build(runner: Path, generated_c: Path, work: Path) -> Path:
    elf = work / "runner-m4.elf"
    command = [
        CROSS,
        *C_FLAGS,
        *ARM_FLAGS,
        "-DMLCA_TARGET",
        "-ffreestanding",
        "-nostartfiles",
        f"-T{SUPPORT / 'm4.ld'}",
        f"-I{generated_c.parent}",
        "-o",
        str(elf),
        str(runner),
        str(generated_c),
        str(SUPPORT / "startup.c"),
        str(SUPPORT / "semihost.c"),
        "-Wl,--gc-sections",
        "-lc",
        "-lgcc",
        "-lnosys",
    ]
    built = run(command, timeout=300)
    if built.returncode != 0:
        raise ToolError(f"error: {CROSS} failed on {runner}:\n{built.output[-3000:]}")
    return elf


def run_on_target(runner: Path, generated_c: Path, work: Path, host_lines: list[str]) -> TargetRun:
    elf = build(runner, generated_c, work)
    size = run(["arm-none-eabi-size", str(elf)]).output.splitlines()[-1].split()
    console = work / "target-output.txt"
    console.unlink(missing_ok=True)
    start = time.perf_counter()
    ran = run(
        [
            QEMU,
            "-M",
            BOARD,
            "-display",
            "none",
            "-monitor",
            "none",
            "-serial",
            "none",
            "-chardev",
            f"file,id=semihosting,path={console}",
            "-semihosting-config",
            "enable=on,target=native,chardev=semihosting",
            "-kernel",
            str(elf),
        ],
        timeout=QEMU_TIMEOUT,
    )
    seconds = time.perf_counter() - start
    text = console.read_text(encoding="utf-8", errors="replace") if console.is_file() else ran.output
    lines = [line.rstrip("\r") for line in text.splitlines()]
    return TargetRun(
        BOARD, lines, len(host_lines), first_difference(host_lines, lines), ran.returncode, seconds, int(size[0])
    )


def first_difference(host: list[str], target: list[str]) -> str:
    for k, (a, b) in enumerate(zip(host, target, strict=False)):
        if a != b:
            return f"line {k + 1}: host {a!r}, target {b!r}"
    if len(host) != len(target):
        return f"host printed {len(host)} lines, target {len(target)}"
    return ""


def summary_line(t: TargetRun) -> str:
    status = "pass" if t.agrees else "FAIL"
    what = "every line as on the host" if t.agrees else t.first_difference or f"exit {t.exit_code}"
    return f"  target {status}  Cortex-M4 on QEMU {t.board}: {len(t.lines)} lines, {what} (text {t.text_bytes} B)"
