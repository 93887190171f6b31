"""The names a spec may give: identifiers that cannot clash with anything the generated code, its harnesses or
the languages define. Pure data and one lookup; the loader reports the clash at the name's position."""

from __future__ import annotations

import keyword
import re

NAME_LIMIT = 64  # characters in a state, input or property name
MAX_STATES = 1_000  # the explicit engine and the generated switch grow with them
MAX_INPUTS = 64
MAX_ELEMENTS = 10_000  # transitions, invariants, liveness properties, comparisons: each kind
MACHINE_NAME_LIMIT = 32  # the machine's name prefixes every generated C name and file name

IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
PROPERTY_ID = re.compile(r"[A-Za-z][A-Za-z0-9_\-.]*")


C_KEYWORDS = frozenset(
    "auto break case char const continue default do double else enum extern float for goto if inline int "
    "long register restrict return short signed sizeof static struct switch typedef union unsigned void "
    "volatile while _Bool _Complex _Imaginary _Alignas _Alignof _Atomic _Generic _Noreturn _Static_assert "
    "_Thread_local main".split()
)
# Object-like macros of the C headers that the generated code, its harnesses and its emitted tests include
# (<stdbool.h>, <stddef.h>, <stdio.h>; `gcc -dM -E`, checked by a test).
C_HEADER_MACROS = frozenset(
    "BUFSIZ EOF FILENAME_MAX FOPEN_MAX L_tmpnam NULL SEEK_CUR SEEK_END SEEK_SET TMP_MAX bool false offsetof "
    "stderr stdin stdout true errno assert".split()
)
# Macros that emitted C tests define around the generated header.
EMITTED_TEST_MACROS = frozenset("CAT CAT2 FSM ST CHECK_FROM STEP_COUNT STEPS FSM_HEADER FSM_PREFIX FSM_MACRO".split())
# Words of ACSL, the contract language of the generated C, that Frama-C's parser reads as keywords in a contract.
ACSL_WORDS = frozenset(
    "boolean integer real let logic predicate lemma axiom axiomatic inductive global ghost model type assigns "
    "ensures requires assumes behavior behaviors complete disjoint decreases terminates loop invariant variant "
    "allocates frees reads writes exits breaks continues returns label slice module contract function include "
    "pragma assert check admit".split()
)
EXPR_WORDS = frozenset(
    {"and", "or", "not", "true", "false", "state", "in", "if", "then", "else", "prev", "min", "max", "abs", "valid"}
)
# The generated header defines <MACHINE>_<STATE> for every state, <MACHINE>_INITIAL, <MACHINE>_FALLBACK, the
# guard <MACHINE>_FSM_H, and for a machine with data <MACHINE>_INVARIANTS and <MACHINE>_FAILING.
GENERATED_STATE_SUFFIXES = frozenset({"INITIAL", "FALLBACK", "FSM_H", "INVARIANTS", "FAILING"})
# Public attributes of the classes that hold states (an IntEnum) and inputs (a dataclass) in generated Python, on
# every Python the project supports (3.11 to 3.13; a test checks the list against the running one).
PYTHON_ATTRIBUTES = frozenset(
    "as_integer_ratio bit_count bit_length conjugate denominator from_bytes imag is_integer mro name numerator "
    "real to_bytes value".split()
)


# Members the generated context holds for itself beside a machine's variables: the mode, the first-step flag and
# the prev() registers (prev0, prev1, ...).
CONTEXT_MEMBERS = frozenset({"mode", "first"})
_REGISTER = re.compile(r"prev[0-9]+")


def _language_clash(name: str) -> str | None:
    if keyword.iskeyword(name):
        return "is a Python keyword"
    if name in C_KEYWORDS:
        return "is a C keyword or reserved name"
    if name in C_HEADER_MACROS:
        return "is a macro of the C standard headers the generated code includes"
    if name in ACSL_WORDS:
        return "is a word of ACSL, the generated C's contract language"
    if name in EXPR_WORDS:
        return "is a word of the expression language"
    if name.startswith(("Py", "PY")):
        return "is in the namespace of Python's C API (names starting Py or PY)"
    return None


def clash(name: str, role: str, machine: str = "") -> str | None:
    """Why `name`, used as a `role` ("state", "input", "machine"), cannot be used ("is a Python keyword",
    "clashes with ..."); None when it is free."""
    if "__" in name:
        return "contains '__', which generated names use to join their parts"
    found = _language_clash(name)
    if found is not None:
        return found
    if role in ("state", "input") and name in EMITTED_TEST_MACROS:
        return "clashes with a macro the emitted C tests define"
    if role in ("state", "input") and name in PYTHON_ATTRIBUTES:
        holder = "the generated State enum (an IntEnum)" if role == "state" else "the generated Inputs class"
        return f"clashes with an attribute of {holder}"
    if (
        role not in ("state", "machine")
        and machine
        and name in {f"{machine.upper()}_{s}" for s in GENERATED_STATE_SUFFIXES}
    ):
        return f"clashes with the macro {name} of the generated C header"
    if role == "variable" and (name in CONTEXT_MEMBERS or _REGISTER.fullmatch(name)):
        return f"clashes with the member '{name}' that the generated context holds for itself; rename the variable"
    if role == "state" and name in GENERATED_STATE_SUFFIXES:
        return f"clashes with the generated C name <MACHINE>_{name}"
    return None
