"""The IEEE 754 formats the generated code may compute reals in: binary64 (`double`, the default) and binary32
(`float`, a spec's `machine.reals = "binary32"`: a Cortex-M4F's FPU is single precision).

Each format rounds a rational exactly (round to nearest, ties to even, subnormals and overflow included), so
the rounding-error bounds (`logic.binary64`), the replay of a trace in the code's arithmetic (`logic.replay64`),
the literals the generator writes and the generated Python's rounding all agree on what the code computes.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from fractions import Fraction
from typing import Literal

Reals = Literal["binary64", "binary32"]
REALS: tuple[Reals, ...] = ("binary64", "binary32")
_SINGLE = struct.Struct("<f")
_BITS = struct.Struct("<I")


@dataclass(frozen=True)
class Format:
    """One binary floating-point format: `precision` significand bits (the hidden one included), the smallest
    subnormal 2^`tiny`, the largest finite value below 2^`top`."""

    name: Reals
    ctype: str  # the C type: "double" or "float"
    precision: int
    tiny: int
    top: int

    @property
    def unit(self) -> Fraction:
        """The unit roundoff: each operation's relative error, away from overflow and underflow."""
        return Fraction(1, 2**self.precision)

    @property
    def underflow(self) -> Fraction:
        """The absolute error a product or quotient may add in the subnormal range: half the smallest subnormal."""
        return Fraction(1, 2 ** (1 - self.tiny))

    @property
    def exact_int(self) -> Fraction:
        """Every integer of at most this magnitude is a value of the format."""
        return Fraction(2**self.precision)

    @property
    def largest(self) -> Fraction:
        return Fraction(2**self.top) - Fraction(2 ** (self.top - self.precision))

    def nearest(self, value: Fraction) -> Fraction | None:
        """The value of the format nearest to `value`, exactly; None where it overflows to an infinity."""
        if value == 0:
            return Fraction(0)
        magnitude = abs(value)
        exponent = max(_floor_log2(magnitude) - self.precision + 1, self.tiny)
        scaled = magnitude / Fraction(2) ** exponent
        whole, rest = divmod(scaled.numerator, scaled.denominator)
        if 2 * rest > scaled.denominator or (2 * rest == scaled.denominator and whole % 2 == 1):
            whole += 1
        rounded = whole * Fraction(2) ** exponent
        if rounded > self.largest:
            return None
        return rounded if value > 0 else -rounded

    def round(self, x: float) -> float:
        """A Python float (binary64) rounded to the format, as a C cast rounds it: NaN and the infinities kept,
        overflow to an infinity."""
        if self.name == "binary64" or math.isnan(x) or math.isinf(x):
            return x
        try:
            return float(_SINGLE.unpack(_SINGLE.pack(x))[0])
        except OverflowError:
            return math.copysign(math.inf, x)

    def next_after(self, x: float, toward: float) -> float:
        """The value of the format next to the format's finite `x`, toward `toward`."""
        if self.name == "binary64" or x == toward or math.isnan(toward):
            return math.nextafter(x, toward)
        bits = _BITS.unpack(_SINGLE.pack(x))[0]
        ordered = -(bits & 0x7FFFFFFF) if bits >> 31 else bits  # the floats in order, -0 and +0 as one
        ordered += 1 if toward > x else -1
        return float(_SINGLE.unpack(_BITS.pack(ordered if ordered >= 0 else -ordered | 0x80000000))[0])

    @property
    def smallest(self) -> float:
        """The smallest positive subnormal."""
        return float(Fraction(1, 2**-self.tiny))

    def of(self, value: Fraction | int) -> float:
        """An exact number (an int, a decimal constant) as the code holds it in the format: rounded once, to
        nearest, as C converts an `int64_t` and reads a constant (not through binary64); an infinity beyond the
        largest value."""
        exact = self.nearest(Fraction(value))
        return math.copysign(math.inf, value) if exact is None else float(exact)


def _floor_log2(magnitude: Fraction) -> int:
    """The exponent e with 2^e <= magnitude < 2^(e+1)."""
    e = magnitude.numerator.bit_length() - magnitude.denominator.bit_length()
    if Fraction(2) ** e > magnitude:
        e -= 1
    elif Fraction(2) ** (e + 1) <= magnitude:
        e += 1
    return e


FORMATS: dict[Reals, Format] = {
    "binary64": Format("binary64", "double", 53, -1074, 1024),
    "binary32": Format("binary32", "float", 24, -149, 128),
}
BY_CTYPE = {f.ctype: f for f in FORMATS.values()}  # the format a C field of this type holds


def shortest_single(value: float) -> str:
    """The shortest decimal that a C compiler reads (rounding it once, to nearest) as the binary32 `value`; with
    a point or an exponent, so that a suffix `f` may follow."""
    single = FORMATS["binary32"]
    text = f"{value:.9g}"  # nine significant digits tell every binary32 apart
    for digits in range(1, 9):
        shorter = f"{value:.{digits}g}"
        if single.nearest(Fraction(shorter)) == Fraction(value):
            text = repr(float(shorter))  # "100.0", not "1e+02"
            break
    return text if any(ch in text for ch in ".e") else text + ".0"
