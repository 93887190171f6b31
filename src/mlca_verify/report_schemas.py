"""The JSON reports as JSON Schemas (draft 2020-12): `check --json`, `conform --json`, the `coverage.json` that
`tests` writes and the evidence bundle's `evidence.json`, each built from the names the writers use (the kinds,
verdicts, engines and checks of the code that writes the report) and shipped as
`mlca_verify/schemas/<report>-<version>.schema.json` (`scripts/report_schemas.py` writes them; a test fails when
they differ from what this module builds). Pure: dicts and their text."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from typing import get_args, get_type_hints

from mlca_verify.check_report import CHECK_SCHEMA
from mlca_verify.conformance import CONFORM_SCHEMA
from mlca_verify.conformance.outcome import CHECKS
from mlca_verify.evidence.collect import EVIDENCE_SCHEMA, TOOL_VERSIONS
from mlca_verify.evidence.coverage import TIMINGS
from mlca_verify.evidence.network import NETWORK_CHECKS, NETWORK_EVIDENCE_SCHEMA
from mlca_verify.json_types import Json, JsonObject
from mlca_verify.layout import FILES
from mlca_verify.logic.results import Engine, Kind
from mlca_verify.model import OTHERWISE_ID, Otherwise, Semantics, Type, Verdict
from mlca_verify.testgen.command import TESTS_SCHEMA
from mlca_verify.testgen.measure import Coverage

DRAFT = "https://json-schema.org/draft/2020-12/schema"
BASE = "https://mlca-verify.invalid/schemas/"
# each report by its name on the command line (`mlca-verify schema --report NAME`), and its schema string
REPORTS = {
    "check": CHECK_SCHEMA,
    "conform": CONFORM_SCHEMA,
    "tests": TESTS_SCHEMA,
    "evidence": EVIDENCE_SCHEMA,
    "network-evidence": NETWORK_EVIDENCE_SCHEMA,
}
UP_TO_DATE = "up-to-date"  # the check `conform` always runs first, before CHECKS
SHA256 = "^[0-9a-f]{64}$"
UTC_SECOND = r"^[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9]{2}:[0-9]{2}:[0-9]{2}\+00:00$"  # evidence.now()
# a number of the spec as the evidence writes it, exactly: an integer, a decimal (a float's repr where a decimal
# would take more than 40 digits), or a fraction the spec's arithmetic made
EXACT_NUMBER = r"^(-?[0-9]+(\.[0-9]+)?(e[-+][0-9]+)?|\(-?[0-9]+ / [0-9]+\))$"


# --- building blocks --------------------------------------------------------------------------------------------


def _typed(kind: Json, description: str, **extra: Json) -> JsonObject:
    return {"description": description, "type": kind, **extra}


def _string(description: str, **extra: Json) -> JsonObject:
    return _typed("string", description, **extra)


def _boolean(description: str) -> JsonObject:
    return _typed("boolean", description)


def _count(description: str) -> JsonObject:
    return _typed("integer", description, minimum=0)


def _seconds(description: str) -> JsonObject:
    return _typed("number", description, minimum=0)


def _enum(values: Iterable[str], description: str) -> JsonObject:
    listed: list[Json] = [v for v in values]
    return {"description": description, "enum": listed}


def _strings(description: str) -> JsonObject:
    return _typed("array", description, items={"type": "string"})


def _array(items: JsonObject, description: str, **extra: Json) -> JsonObject:
    return _typed("array", description, items=items, **extra)


def _ref(name: str, description: str) -> JsonObject:
    return {"description": description, "$ref": f"#/$defs/{name}"}


def _ref_or_null(name: str, description: str) -> JsonObject:
    return {"description": description, "anyOf": [{"$ref": f"#/$defs/{name}"}, {"type": "null"}]}


def _map(values: JsonObject, description: str) -> JsonObject:
    """An object whose keys are names of the user's (inputs, signals, functions): each value of one schema."""
    return _typed("object", description, additionalProperties=values)


def _object(
    properties: Mapping[str, JsonObject],
    description: str,
    *,
    optional: Iterable[str] = (),
    nullable: bool = False,
    **extra: Json,
) -> JsonObject:
    """An object with a fixed set of keys, all required but `optional`, and no other."""
    left_out = set(optional)
    required: list[Json] = [k for k in properties if k not in left_out]
    kinds: Json = ["object", "null"] if nullable else "object"
    shown: JsonObject = dict(properties)
    return _typed(kinds, description, properties=shown, required=required, additionalProperties=False, **extra)


def _without(schema: JsonObject, *keys: str) -> JsonObject:
    """`schema` (an object's) without the properties `keys`: a report that leaves them out."""
    properties = schema["properties"]
    required = schema["required"]
    assert isinstance(properties, dict) and isinstance(required, list)
    kept = {k: v for k, v in properties.items() if k not in keys}
    return {**schema, "properties": kept, "required": [k for k in required if k not in keys]}


def _document(
    report: str,
    description: str,
    properties: Mapping[str, JsonObject],
    defs: Mapping[str, JsonObject],
    optional: Iterable[str] = (),
) -> JsonObject:
    """A report's schema: its schema string first, then `properties`, every one required but `optional`."""
    name = REPORTS[report]
    shown: JsonObject = {"schema": {"description": "The report's schema string.", "const": name}, **properties}
    left_out = set(optional)
    required: list[Json] = [k for k in shown if k not in left_out]
    return {
        "$schema": DRAFT,
        "$id": BASE + file_name(report),
        "title": f"mlca-verify {report} report ({name})",
        "description": description,
        "type": "object",
        "properties": shown,
        "required": required,
        "additionalProperties": False,
        "$defs": dict(defs),
    }


# --- check --json ------------------------------------------------------------------------------------------------

_VALUE: JsonObject = {"type": ["number", "boolean"]}


def _values(description: str) -> JsonObject:
    return _map(_VALUE, description + " Each key is a name of the spec, each value a number or a boolean.")


def _outcome_properties() -> dict[str, JsonObject]:
    return {
        "transition": _typed(
            ["string", "null"],
            f'The id of the transition that fires; "{OTHERWISE_ID}" where none is enabled and a machine without '
            "data keeps its state; null where none fires (a machine with data, a stuck machine, a lemma's "
            "valuation).",
        ),
        "cite": _typed(["string", "null"], "The transition's cite; null where no transition fires."),
        "next": _typed(
            ["string", "null"], "The state after the step; null where the machine is stuck, and in a lemma's valuation."
        ),
        "machine": _string("Which of two machines compared this outcome is of (a comparison's steps only)."),
    }


def _check_defs(networks: bool = False) -> dict[str, JsonObject]:
    """The definitions a result needs; with `networks` (check's), a network run's messages too."""
    verdicts = get_args(Verdict)
    step = {
        "state": _string("The state before the step."),
        "inputs": _map({"type": "boolean"}, "The boolean inputs of the step, by name."),
        **_outcome_properties(),
        "alternatives": _array(
            _ref("outcome", "Another outcome."),
            "Other outcomes of the same state and inputs, where the check is about them (nondeterminism, two "
            "machines that differ); left out otherwise.",
        ),
        "signals": _values("The step's samples (a machine with data); an invalid one is a number outside its range."),
        "definitions": _values("The definitions as the step's guards saw them, before the step (a machine with data)."),
        "variables": _values("The variables after the step (a machine with data)."),
        "outputs": _values("The outputs after the step (a machine with data)."),
    }
    optional_step = ("machine", "alternatives", "signals", "definitions", "variables", "outputs")
    return {
        "verdict": _enum(verdicts, "A verdict: holds, violated or unknown."),
        "outcome": _object(_outcome_properties(), "One possible result of a step.", optional=("machine",)),
        "step": _object(step, "One step of a trace: the state and inputs, and what fired.", optional=optional_step),
        "counterexample": _object(
            {
                "steps": _array(_ref("step", "A step."), "The trace from the initial state, a step per item."),
                "loop_start": _typed(
                    ["integer", "null"],
                    "Where a lasso's loop starts (the steps from this index on repeat forever); null for a finite "
                    "trace.",
                    minimum=0,
                ),
                "params": _values("The param values of the run (a machine with data)."),
                "point": {
                    "description": "A lemma's counterexample: one valuation, not a run (its one step holds them).",
                    "const": True,
                },
                **({"messages": _array(_ref("message", "A message."), _MESSAGES)} if networks else {}),
            },
            "A trace that shows the verdict: a counterexample, or the witness of a reachability check.",
            optional=("params", "point", "messages"),
        ),
        **({"message": _message()} if networks else {}),
        "proof": _object(
            {
                "engine": _enum(
                    get_args(Engine),
                    "The engine that decided: explicit (the explicit-state search), bmc, k-induction, pdr, "
                    "k-induction+pdr (neither answered), abstraction (a bad run of the abstraction that no real run "
                    'follows: unknown), lasso (a response without a bound), or "" where none did.',
                ),
                "parametric": _boolean("Whether the params were free in their ranges (else at their defaults)."),
                "k": _typed(
                    ["integer", "null"],
                    "The k that closed the induction, the length of the run BMC found, the largest k tried before "
                    "PDR, or the lasso bound; null where none applies.",
                    minimum=0,
                ),
                "certificate": _typed(
                    ["string", "null"],
                    "PDR's inductive invariant in SMT-LIB text over the frame's constants; null where there is none.",
                ),
                "certificate_checked": _boolean("Whether separate queries confirmed the certificate."),
                "assumptions": _strings("The ids of the [[assume]] tables the proof rests on."),
                "notes": _strings("What the engine adds: why there is no certificate, why the verdict is unknown."),
            },
            "How a property of a machine with data was decided by a search.",
        ),
    }


_MESSAGES = (
    "A network's run only: every message its channels carried (for a boolean output, each true one), channel by "
    "channel in the order sent, with the steps at which it was read and lost (what the terminal's message sequence "
    "chart draws)."
)


def _message() -> JsonObject:
    steps: JsonObject = {"type": "integer", "minimum": 1}
    return _object(
        {
            "channel": _string("The channel's id."),
            "sent": _typed("integer", "The step after which the sender held it (1: after the first step).", minimum=1),
            "value": {"description": "What it carried: the output's value (a boolean as 0 or 1).", "type": "number"},
            "heard": _array(steps, "The steps at which the receiver read it."),
            "lost": _array(steps, "The steps at which it was to be read and was lost."),
        },
        "One message of a network's run.",
    )


def _network() -> JsonObject:
    instance = _object(
        {
            "name": _string("The instance's name (the prefix of its qualified names)."),
            "spec": _string("Its machine spec, as the network names it."),
            "machine": _string("Its machine's name."),
            "cite": _string("Its cite."),
        },
        "One instance.",
    )
    count: JsonObject = {"type": "integer", "minimum": 0}
    channel = _object(
        {
            "id": _string("The channel's id."),
            "from": _string("The sender's output, qualified (A.claims)."),
            "to": _string("The receiver's input or signal, qualified (B.heard)."),
            "delay": _typed("integer", "The fewest steps a message takes (0: read in the step it is sent).", minimum=0),
            "max_delay": _typed("integer", "The most steps a message takes (delay when it is exact).", minimum=0),
            "order": _enum(("fifo", "any"), "Whether late messages are read in the order sent."),
            "duplicate": _boolean("In order: whether a late step may read again the message read the step before."),
            "lost": {**count, "description": "The most messages lost in a row."},
            "cite": _string("Its cite."),
        },
        "One channel.",
    )
    return _object(
        {
            "schedule": _enum(("synchronous", "interleaved"), "Whether the instances step together or in turn."),
            "fairness": {
                **count,
                "description": "Interleaved: each steps at least once in every so many (0: no bound).",
            },
            "instances": _array(instance, "The instances, in the spec's order."),
            "channels": _array(channel, "The channels, in the spec's order."),
        },
        "A network spec only: its instances, channels and schedule, which its results' names and messages refer to.",
    )


def _result(timed: bool) -> JsonObject:
    """The verdict on one property, as `check --json` writes it (with its seconds) or the evidence (without)."""
    result = _object(
        {
            "property": _string("The property's name: a declared id, or a built-in check's (reach:S, fires:T, ...)."),
            "kind": _enum(get_args(Kind), "What kind of property it is."),
            "verdict": _ref("verdict", "The verdict found."),
            "expected": _ref("verdict", "The verdict the spec expects."),
            "ok": _boolean("Whether the verdict is the one expected."),
            "cite": _string("Where the property comes from (its cite in the spec)."),
            "seconds": _seconds("How long it took to decide."),
            "detail": _string("What shows the verdict, or why it is unknown, in a line or a few."),
            "counterexample": _ref_or_null("counterexample", "The trace that shows the verdict; null where none."),
            "proof": _ref("proof", "How it was decided: a machine with data's properties decided by a search only."),
            "caveat": _string(
                "Why a verdict decided over the reals is not shown to carry over to the code's binary64; left out "
                "where it is.",
                minLength=1,
            ),
        },
        "The verdict on one property.",
        optional=("proof", "caveat"),
    )
    return result if timed else _without(result, "seconds")


def check_schema() -> JsonObject:
    """The schema of `mlca-verify check --json FILE`."""
    spec = _object(
        {
            "path": _string("The spec file, as given on the command line."),
            "sha256": _string("The SHA-256 of the spec file's bytes.", pattern=SHA256),
            "machine": _string("The machine's name."),
            "results": _array(_ref("result", "A result."), "Every result, in the order checked (after --only)."),
            "network": _network(),
        },
        "One spec checked.",
        optional=("network",),
    )
    return _document(
        "check",
        "What `mlca-verify check --json FILE` writes: for each spec, the verdict on every built-in check and "
        "declared property, and what shows it.",
        {"specs": _array(spec, "Each spec checked, in the order given.")},
        {**_check_defs(networks=True), "result": _result(timed=True)},
    )


# --- conform --json ----------------------------------------------------------------------------------------------


def _wp_goals() -> dict[str, JsonObject]:
    """What a Frama-C WP run reports (all four, or none where Frama-C reported no proof)."""
    goal = _object(
        {
            "goal": _string("The goal's name as WP gives it."),
            "prover": _string("The prover that decided it (Qed, Z3 and its version, ...)."),
            "status": _string("WP's status: Valid, Unknown, Timeout, Stepout, Failed."),
        },
        "One goal.",
    )
    return {
        "proved": _count("Goals proved."),
        "goals": _count("Goals in all."),
        "unproved": _strings("The goals not proved, each with what its status means."),
        "goal_list": _array(goal, "Every goal, sorted."),
    }


def _together(keys: Iterable[str]) -> JsonObject:
    """dependentRequired: each of `keys` present only with all the others."""
    names = list(keys)
    return {k: [other for other in names if other != k] for k in names}


def _conform_data() -> dict[str, JsonObject]:
    """The data each check writes, by its name. A check that did not get as far as its figures (a failure, or a
    check that runs the code when the code did not compile) writes none of them."""
    nothing = _object({}, "Nothing: the check writes no data.")
    wp = _wp_goals()
    certified = _object(
        {
            **wp,
            "stated": _strings("The invariants stated on the step with their certificates."),
            "left": _strings("The invariants proved by the engine but not stated, each with why."),
            "in_reach": _strings(
                "The variables whose range the step requires but cannot keep from every context (left to the "
                "engine's range: checks)."
            ),
        },
        "The proof of the invariants on a wrapper of the step, with their certificates as precondition.",
        optional=wp,
        dependentRequired=_together(wp),
    )
    stack = _map({"type": "integer"}, "Each function's own stack frame in bytes, by name.")
    return {
        UP_TO_DATE: nothing,
        "compile": nothing,
        "exhaustive": _object(
            {
                "steps": _count("Steps of the boundary set."),
                "restarts": _count("Steps from a mode that names no state."),
            },
            "The boundary set's figures.",
            optional=("steps", "restarts"),
            dependentRequired=_together(("steps", "restarts")),
        ),
        "sequences": _object(
            {
                "steps": _count("Steps run."),
                "unproved_failing": _strings("The invariants the engine does not prove that failed in a run."),
            },
            "The random runs' figures.",
            optional=("steps", "unproved_failing"),
            dependentRequired=_together(("steps", "unproved_failing")),
        ),
        "frama-c-wp": _object(
            {
                **wp,
                "binary64": _strings("The clauses labelled binary64, left to the exhaustive and sequence checks."),
                "certified": certified,
            },
            "Frama-C WP's goals on the step (and the outputs' function).",
            optional=[*wp, "certified"],
            dependentRequired=_together(wp),
        ),
        "cppcheck": _object({"findings": _strings("cppcheck's findings, a line each.")}, "cppcheck's findings."),
        "cortex-m4": _object(
            {
                "text": _count("Bytes of code."),
                "data": _count("Bytes of initialised data."),
                "bss": _count("Bytes of zeroed data."),
                "stack": stack,
                "calls": _strings(
                    "The functions the object calls but does not define: the compiler's binary64 helpers (a "
                    "library's fails the check)."
                ),
            },
            "The object built for a Cortex-M4.",
            optional=("text", "data", "bss", "stack", "calls"),
            dependentRequired=_together(("text", "data", "bss", "stack", "calls")),
        ),
        "sanitizers": nothing,
    }


def _conform_check(timed: bool) -> JsonObject:
    names = (UP_TO_DATE, *CHECKS)
    check = _object(
        {
            "name": _enum(names, f"The check: {UP_TO_DATE} (always run), then those asked for, in this order."),
            "ok": _boolean("Whether it passed."),
            "detail": _string("What it found, in a line or a few."),
            "seconds": _seconds("How long it took."),
            "data": _typed("object", "The check's figures; which keys depends on the check."),
        },
        "The outcome of one check.",
    )
    check["allOf"] = [
        {
            "if": {"properties": {"name": {"const": name}}, "required": ["name"]},
            "then": {"properties": {"data": {"$ref": f"#/$defs/data-{name}"}}},
        }
        for name in names
    ]
    return check if timed else _without(check, "seconds")


def _conform_defs() -> dict[str, JsonObject]:
    return {f"data-{name}": data for name, data in _conform_data().items()}


def conform_schema() -> JsonObject:
    """The schema of `mlca-verify conform --json FILE`."""
    spec = _object(
        {
            "path": _string("The spec file, as given on the command line."),
            "sha256": _string("The SHA-256 of the spec file's bytes.", pattern=SHA256),
            "machine": _string("The machine's name."),
            "ok": _boolean("Whether every check passed."),
            "checks": _array(_ref("check", "A check."), "Each check, in the order run."),
        },
        "The checks of one spec's generated code.",
    )
    return _document(
        "conform",
        "What `mlca-verify conform --json FILE` writes: for each spec, the outcome of each check of its generated "
        "code.",
        {"specs": _array(spec, "Each spec, in the order given.")},
        {"check": _conform_check(timed=True), **_conform_defs()},
    )


# --- tests: coverage.json ----------------------------------------------------------------------------------------


def _tests_defs() -> dict[str, JsonObject]:
    figure = _object(
        {
            "covered": _count("Covered."),
            "total": _count("In all."),
            "percent": _typed("number", "covered / total in percent, 100 where there is none.", minimum=0, maximum=100),
        },
        "A coverage figure.",
    )
    function = _object(
        {
            "statements": _ref("figure", "Statements (Python)."),
            "branches": _ref("figure", "Branches."),
            "mcdc": _ref("figure", "MC/DC conditions (C)."),
        },
        "One function's figures: statements and branches for the Python, branches and MC/DC for the C.",
        optional=("statements", "branches", "mcdc"),
    )
    gap = _object(
        {
            "line": _typed("integer", "The line of the generated file.", minimum=0),
            "what": _string("What is not covered there."),
            "reason": _string('Why the suite cannot cover it; "" where no reason is known (the command fails).'),
        },
        "Something the suite leaves uncovered.",
    )
    languages = get_args(get_type_hints(Coverage)["language"])
    coverage = _object(
        {
            "language": _enum(languages, "Which generated file: the Python or the C."),
            "file": _string("The generated file's name."),
            "passed": _boolean("Whether the suite passed under coverage."),
            "statements": _ref("figure", "Statements (lines for the C)."),
            "branches": _ref("figure", "Branches (each side of each condition for the C)."),
            "mcdc": _ref_or_null("figure", "MC/DC conditions; null for the Python (coverage.py measures none)."),
            "functions": _map(_ref("function", "A function's figures."), "Each function's figures, by name."),
            "gaps": _array(gap, "Each gap, with its reason."),
            "notes": _strings("What the tool says it could not measure."),
        },
        "The suite's coverage of one generated file.",
    )
    return {"figure": figure, "function": function, "coverage": coverage}


def _tests_properties(timed: bool) -> dict[str, JsonObject]:
    exception = _object(
        {
            "objective": _string("The objective's id."),
            "condition": _string("The condition and the decision it is in."),
            "reason": _string("z3's reason it has no pair."),
        },
        "A condition without an MC/DC pair.",
    )
    host = _object(
        {
            "passed": _boolean("Whether the C suite passed on the host."),
            "last": _string('Its last line of output ("N passed, N failed"); "" where it printed none.'),
        },
        "The C suite built by gcc and run on the host.",
    )
    target = _object(
        {
            "board": _string("QEMU's board."),
            "cpu": {"description": "The processor.", "const": "cortex-m4"},
            "lines": _count("Lines the target printed."),
            "host_lines": _count("Lines the host printed."),
            "agrees": _boolean("Whether every line agrees with the host's and the run exited 0."),
            "first_difference": _string('The first line that differs; "" where every line agrees.'),
            "exit_code": _typed("integer", "The run's exit code."),
            "seconds": _seconds("How long the run took."),
            "text_bytes": _count("Bytes of code of the program built for the target."),
        },
        "The suite on a Cortex-M4 under QEMU; null with --no-target.",
        nullable=True,
    )
    properties = {
        "spec": _string("The spec file, as given."),
        "sha256": _string("The SHA-256 of the spec file's bytes.", pattern=SHA256),
        "machine": _string("The machine's name."),
        "seconds": _seconds("How long generating the suite took."),
        "runs": _count("Runs of the suite."),
        "steps": _count("Steps in all its runs."),
        "monitor_calls": _count("Calls of the monitor on a chosen context."),
        "params_checks": _count("Checks of the params just outside their ranges."),
        "objectives": _count("Conditions to pair (MC/DC objectives)."),
        "paired": _count("Conditions paired."),
        "exceptions": _array(exception, "The conditions without a pair, each with z3's reason."),
        "host": host,
        "coverage": _array(
            _ref("coverage", "A file's coverage."), "Coverage of the Python, then the C; [] with --no-coverage."
        ),
        "target": target if timed else _without(target, "seconds"),
    }
    return properties if timed else {k: v for k, v in properties.items() if k not in TIMINGS}


def tests_schema() -> JsonObject:
    """The schema of the `coverage.json` that `mlca-verify tests` writes for each machine."""
    return _document(
        "tests",
        "What `mlca-verify tests` writes as OUT/<machine>/coverage.json: the generated suite, its coverage of the "
        "generated Python and C, and its run on a Cortex-M4.",
        _tests_properties(timed=True),
        _tests_defs(),
    )


# --- the evidence bundle: evidence.json --------------------------------------------------------------------------


def _spec_part() -> JsonObject:
    return _object(
        {
            "path": _string("The spec file, as given."),
            "sha256": _string("The SHA-256 of the spec file's bytes.", pattern=SHA256),
            "machine": _string("The machine's name."),
            "cite": _string("The machine's cite."),
            "states": _array({"type": "string"}, "Its states.", minItems=1),
            "initial": _string("Its initial state."),
            "fallback": _string("The state generated code restarts a corrupted context in."),
            "reals": _string(
                "The IEEE 754 format the generated code computes reals in (left out by bundles written before "
                "binary32).",
                enum=["binary64", "binary32"],
            ),
            "dot": _string("Its diagram in Graphviz DOT."),
        },
        "The machine.",
        optional=["reals"],
    )


def _file(description: str, kinds: Iterable[str] | None = None) -> JsonObject:
    properties = {
        "path": _string("The file's path (a template's as templates/<name>)."),
        "sha256": _string("The SHA-256 of its bytes.", pattern=SHA256),
    }
    if kinds is not None:
        properties = {"kind": _enum(kinds, "Which generated file."), **properties}
    return _object(properties, description)


def _closed_loop() -> JsonObject:
    fired = _object(
        {"transition": _string("A transition's id."), "fired": _count("Times it fired in the runs.")},
        "How often a transition fired.",
    )
    counts = ("db", "sha256", "runs", "failed_runs", "monitor_violations")
    section = _object(
        {
            "status": _enum(("undeveloped", "ok", "failed"), "undeveloped where no results database was given."),
            "detail": _string("What the runs show, in a line."),
            "db": _string("The results database."),
            "sha256": _string("The SHA-256 of the database.", pattern=SHA256),
            "runs": _count("Closed-loop runs of this machine's controllers."),
            "failed_runs": _count("Runs that failed."),
            "monitor_violations": _count("Violations the runtime monitor reported."),
            "transitions": _array(fired, "Each transition of the spec (where the database records them)."),
            "coverage": _string("How many transitions fired, in a line (with transitions)."),
        },
        "The closed-loop runs of the generated controllers (--db).",
        optional=(*counts, "transitions", "coverage"),
        dependentRequired=_together(("transitions", "coverage")),
    )
    section["if"] = {"properties": {"status": {"const": "undeveloped"}}, "required": ["status"]}
    section["then"] = {"propertyNames": {"enum": ["status", "detail"]}}
    section["else"] = {"required": list(counts)}
    return section


def _traceability() -> JsonObject:
    line = _object(
        {"file": _string("A generated file."), "line": _typed("integer", "A line.", minimum=1)},
        "A line of generated code that implements the element.",
    )
    return _object(
        {
            "cite": _string("The element's cite."),
            "element": _string('The spec element: "transition <id>", "invariant <id>" or "liveness <id>".'),
            "text": _string("The element in the spec's syntax."),
            "property": _string("The property that checks it (fires:<id> for a transition)."),
            "verdict": _ref("verdict", "Its verdict."),
            "expected": _ref("verdict", "The verdict expected."),
            "ok": _boolean("Whether the verdict is the one expected."),
            "code": _array(line, "Where the generated C and Python implement it."),
            "tests": _strings("The checks that test it."),
        },
        "A row of the traceability matrix.",
    )


def _readings() -> JsonObject:
    difference = _object(
        {
            "state": _string("A state both readings reach."),
            "when": _string("The inputs on which they differ."),
            "canonical": _strings("What the canonical reading does then."),
            "this": _strings("What this reading does then."),
        },
        "Where a reading differs from the canonical one.",
    )
    machine = _object(
        {
            "path": _string("The reading's spec file."),
            "machine": _string("Its machine's name."),
            "cite": _string("Its cite."),
            "semantics": _enum(get_args(Semantics), "How it chooses a transition."),
            "otherwise": _enum(get_args(Otherwise), "What it does where no transition is enabled."),
            "dot": _string("Its diagram in DOT, the edges that differ from the canonical reading marked."),
            "differences": _array(difference, "Where it differs from the canonical reading."),
        },
        "One reading.",
    )
    return _object(
        {
            "canonical": _typed(["string", "null"], "The canonical reading's machine; null where none is shown."),
            "machines": _array(machine, "Each reading, canonical first."),
        },
        "Readings of the source side by side (--readings).",
    )


def _argument() -> JsonObject:
    return _object(
        {
            "id": _string("The node's id (G1, S1, Sn2.1, C1, A1, ...)."),
            "type": _enum(
                ("goal", "strategy", "solution", "context", "undeveloped", "assumption"), "The kind of GSN node."
            ),
            "text": _string("What it says."),
            "parent": _typed(["string", "null"], "The id of the node it supports; null for the top goal."),
            "ok": _typed(["boolean", "null"], "Whether it is supported; null for a node that claims nothing."),
            "link": _typed(["string", "null"], "The anchor in index.html of its evidence; null where none."),
        },
        "A node of the GSN-style argument.",
    )


def _data_machine() -> JsonObject:
    number: JsonObject = {"type": "string", "pattern": EXACT_NUMBER}
    kind = _enum(get_args(Type), "Its type.")
    bounds = _typed(
        ["array", "null"], "[low, high], exactly; null where it has none.", items=number, minItems=2, maxItems=2
    )
    common = {"doc": _string("Its doc."), "cite": _string("Its cite.")}
    reads = _strings("The signals it reads.")
    return _object(
        {
            "step_s": _typed(
                ["string", "null"], "The seconds of one step, exactly; null where not given.", pattern=EXACT_NUMBER
            ),
            "params": _array(
                _object(
                    {
                        "name": _string("Its name."),
                        "type": kind,
                        "default": {"description": "Its default, exactly.", **number},
                        "range": bounds,
                        "unit": _string('Its unit ("" where none).'),
                        **common,
                    },
                    "A param.",
                ),
                "The params.",
            ),
            "signals": _array(
                _object(
                    {
                        "name": _string("Its name."),
                        "type": kind,
                        "unit": _string('Its unit ("" where none).'),
                        "range": bounds,
                        **common,
                    },
                    "A signal.",
                ),
                "The signals.",
            ),
            "variables": _array(
                _object(
                    {
                        "name": _string("Its name."),
                        "type": kind,
                        "initial": {"description": "Its initial value, exactly.", **number},
                        "range": bounds,
                        "unit": _string('Its unit ("" where none).'),
                        "every": _typed(
                            ["string", "null"], "Its value after a step in which no transition updates it; null: kept."
                        ),
                        **common,
                    },
                    "A variable.",
                ),
                "The variables.",
            ),
            "definitions": _array(
                _object(
                    {
                        "name": _string("Its name."),
                        "type": kind,
                        "expr": _string("Its expression."),
                        "unit": _string('Its unit ("" where none).'),
                        "if_invalid": _typed(
                            ["boolean", "null"], "Its value on an invalid sample (a boolean one that reads signals)."
                        ),
                        "signals": reads,
                        **common,
                    },
                    "A definition.",
                ),
                "The definitions.",
            ),
            "outputs": _array(
                _object(
                    {
                        "name": _string("Its name."),
                        "type": kind,
                        "expr": _string("Its expression."),
                        "unit": _string('Its unit ("" where none).'),
                        "range": bounds,
                        "signals": reads,
                        **common,
                    },
                    "An output.",
                ),
                "The outputs.",
            ),
            "assumptions": _array(
                _object(
                    {
                        "id": _string("Its id."),
                        "expr": _string("Its expression."),
                        **common,
                        "relied_on_by": _strings("The properties whose proofs rest on it."),
                    },
                    "An environment assumption.",
                ),
                "The [[assume]] tables.",
            ),
        },
        "The machine's data, numbers as exact text (empty lists for a machine without data).",
    )


def _physical_safety() -> tuple[JsonObject, JsonObject]:
    """The section, and a replayed point (a definition of its own: both the lemmas and the replays list them)."""
    phase = _object(
        {
            "name": _string("The phase's name."),
            "unsafe": _boolean("Whether it collided or a vehicle braked beyond its limit."),
            "collisions": _array(
                _array({"type": "string"}, "Two vehicle ids.", minItems=2, maxItems=2), "The collisions."
            ),
            "min_gap_lead_m": _typed(["number", "null"], "The smallest gap to the lead vehicle (m)."),
            "min_gap_follow_m": _typed(["number", "null"], "The smallest gap to the following vehicle (m)."),
            "beyond": _strings("The vehicles that braked beyond their limit."),
        },
        "A replayed phase.",
    )
    safety = ("safe", "unsafe")
    replayed = _object(
        {
            "source": _string("Where the point comes from."),
            "point": _map({"type": "number"}, "The values replayed, by name."),
            "expect": _enum(safety, "What the replay was expected to show."),
            "outcome": _enum(safety, "What it showed."),
            "as_expected": _boolean("Whether outcome is expect."),
            "phases": _array(phase, "Its phases."),
        },
        "A lemma counterexample replayed in SUMO (mlca-sim replay --json).",
    )
    lemma = _object(
        {
            "id": _string("Its id."),
            "expr": _string("Its expression."),
            "doc": _string("Its doc."),
            "cite": _string("Its cite."),
            "parametric": _boolean("Whether it is claimed for every param value in range."),
            "params": _strings("The params it reads."),
            "verdict": _ref("verdict", "Its verdict."),
            "expected": _ref("verdict", "The verdict expected."),
            "ok": _boolean("Whether the verdict is the one expected."),
            "detail": _string("What shows the verdict."),
            "smt2": _string("Its SMT-LIB 2 query in the bundle.", pattern=r"^smt2/.+\.smt2$"),
            "smt2_sha256": _string("The SHA-256 of the query.", pattern=SHA256),
            "replays": _array(_ref("replayed", "A replay."), "Its counterexample's replays, of this very spec."),
        },
        "A [[lemma]].",
    )
    agreement = _object(
        {
            "name": _string("The rss_* definition."),
            "rear": _string("The signal that is the speed of the vehicle behind."),
            "front": _string("The other speed signal."),
            "points": _typed("integer", "Points compared.", minimum=1),
            "max_difference_m": _typed("number", "The largest difference from ad-rss-lib (m).", minimum=0),
            "ok": _boolean("Whether it is within 1 mm."),
        },
        "An RSS distance compared with ad-rss-lib.",
    )
    rss = _object(
        {
            "status": _enum(("ok", "failed", "not run", "none"), "none where the spec has no RSS distance."),
            "detail": _string("What the comparison shows, in a line."),
            "definitions": _array(
                {"oneOf": [{"type": "string"}, agreement]},
                "Each RSS distance compared; only its name where ad-rss-lib is not installed.",
            ),
        },
        "The spec's RSS distances against Intel's ad-rss-lib.",
    )
    replay = _object(
        {
            "given": _boolean("Whether replays were given (--replay)."),
            "points": _array(_ref("replayed", "A replay."), "The replays of this spec."),
            "other_specs": _count("Replays given of other specs (by sha256), left out."),
        },
        "The replays given.",
    )
    section = _object(
        {"lemmas": _array(lemma, "Each lemma."), "ad_rss_lib": rss, "replay": replay},
        "The lemmas, their cross-check with ad-rss-lib and their replays (a spec with lemmas).",
    )
    return section, replayed


def _bundle_head(subject: str, part: JsonObject) -> dict[str, JsonObject]:
    """What every bundle's evidence.json begins with: when, what of (`subject`), whether it holds, and the tools."""
    tools: list[Json] = ["mlca-verify", "python", "z3 (Python, proofs of the spec)", *TOOL_VERSIONS]
    return {
        "generated_at": _string(
            "When the bundle was made, in UTC to the second (SOURCE_DATE_EPOCH where set).",
            format="date-time",
            pattern=UTC_SECOND,
        ),
        subject: part,
        "ok": _boolean("Whether every claim is supported."),
        "tools": _typed(
            "object",
            "The version of each tool, by name; not installed where missing.",
            required=tools,
            additionalProperties={"type": "string"},
        ),
    }


def evidence_schema() -> JsonObject:
    """The schema of the evidence bundle's `evidence.json` (`mlca-verify evidence SPEC --out DIR`)."""
    physical, replayed = _physical_safety()
    tested = _object(
        {
            "schema": {"description": "The schema string of the report `tests` writes.", "const": TESTS_SCHEMA},
            **_tests_properties(timed=False),
            "status": _enum(("ok", "failed"), "Whether the suite passed, covered and agreed on the target."),
            "folder": _string("The suite's folder, relative to the bundle."),
            "files": _strings("The files in it."),
            "closed_loop": _string("The closed loop's transition coverage, in a line."),
            "detail": _string("The suite in a line."),
        },
        "The generated test suite and its coverage, as `tests` writes it but for durations (without --no-tests).",
    )
    properties: dict[str, JsonObject] = {
        **_bundle_head("spec", _spec_part()),
        "inputs": _array(_file("An input."), "The specs and templates, with their hashes.", minItems=1),
        "artifacts": _array(_file("A generated file.", FILES), "The generated files, with their hashes."),
        "proofs": _array(_ref("result", "A result."), "Every result of the spec's checks."),
        "conformance": _array(_ref("check", "A check."), "Every conformance check of the generated code."),
        "closed_loop": _closed_loop(),
        "traceability": _array(_traceability(), "Each transition, invariant and liveness property."),
        "readings": _readings(),
        "argument": _array(_argument(), "The argument's nodes, the top goal first.", minItems=1),
        "data_machine": _data_machine(),
        "physical_safety": physical,
        "test_coverage": tested,
    }
    defs = {
        **_check_defs(),
        "result": _result(timed=False),
        "check": _conform_check(timed=False),
        **_conform_defs(),
        **_tests_defs(),
        "replayed": replayed,
    }
    return _document(
        "evidence",
        "What `mlca-verify evidence SPEC --out DIR` writes as DIR/evidence.json: the proofs, the generated code's "
        "conformance, hashes, tool versions, traceability, readings and a GSN-style argument.",
        properties,
        defs,
        optional=("physical_safety", "test_coverage"),
    )


# --- evidence.json of a network ------------------------------------------------------------------------------


def _network_part() -> JsonObject:
    instance = _object(
        {
            "name": _string("The instance's name."),
            "spec": _string("Its machine spec, as the network names it."),
            "machine": _string("Its machine's name."),
            "cite": _string("The instance's cite."),
        },
        "An instance.",
    )
    channel = _object(
        {
            "id": _string("The channel's id."),
            "text": _string("What it carries and how, in the words of `check`."),
            "delay": _count("The fewest steps a message takes."),
            "max_delay": _count("The most steps a message takes."),
            "lost": _count("The most messages lost in a row (0: none)."),
            "cite": _string("The channel's cite."),
        },
        "A channel: what every verdict assumes of it.",
    )
    return _object(
        {
            "path": _string("The network spec file, as given."),
            "sha256": _string("The SHA-256 of its bytes.", pattern=SHA256),
            "name": _string("The network's name."),
            "cite": _string("The network's cite."),
            "schedule": _enum(("synchronous", "interleaved"), "How the instances step."),
            "instances": _array(instance, "Its instances.", minItems=1),
            "channels": _array(channel, "Its channels."),
        },
        "The network.",
    )


def _vehicle() -> JsonObject:
    return _object(
        {
            "instances": _strings("The instances that run this machine with these params."),
            "spec": _string("The machine spec, as the network names it."),
            "machine": _string("The machine's name."),
            "params": _map(_string("A value, as a spec writes it."), "Each param's value in these instances."),
            "proofs": _array(_ref("result", "A result."), "Every result of the machine's checks at these params."),
        },
        "A vehicle: the instances that run one machine with the same params, and its verdicts there.",
    )


def _machine_code() -> JsonObject:
    check = _object(
        {
            "name": _enum((UP_TO_DATE, *NETWORK_CHECKS), "The check."),
            "ok": _boolean("Whether it passed."),
            "detail": _string("Its outcome, in a line or a few."),
        },
        "A check of the machine's generated code.",
    )
    return _object(
        {
            "spec": _string("The machine spec."),
            "machine": _string("The machine's name."),
            "checks": _array(check, "The checks of a network's bundle, up-to-date first."),
            "files": _array(_file("A generated file.", FILES), "The generated files, with their hashes."),
        },
        "A machine's generated code, shared by its instances.",
    )


def _v2v_loop() -> JsonObject:
    section = _closed_loop()
    properties = section["properties"]
    assert isinstance(properties, dict)
    section["properties"] = {
        **properties,
        "status": _enum(
            ("ok", "failed"), "failed where a run failed, the monitor objected or two AVs moved into one lane."
        ),
        "controllers": _string("The machine's controllers whose runs these are (its Python and its C)."),
        "v2v": _map(
            _count("A count."), "What the radio carried in these runs (sent, lost, late, duplicated, conflicts)."
        ),
    }
    return section


def _scene() -> JsonObject:
    return _object(
        {
            "source": _string("The counterexample: its spec and property."),
            "lanes": _map(_count("A lane index."), "Each AV's lane."),
            "controllers": _map(_string("A controller."), "The controller that drove each AV."),
            "radio": _map(_count("Steps or messages."), "The radio at its worst: lost in a row, and delay."),
            "moved_s": _map(_seconds("When."), "When each AV changed lane."),
            "conflicts": _count("Times two AVs began moving into one lane near each other."),
            "collisions": _array(_strings("The vehicles of a collision."), "SUMO's collisions."),
            "messages": _map(_count("Messages."), "Messages sent and lost."),
            "outcome": _enum(("conflict", "none"), "Whether the conflict happened in SUMO."),
            "expected": _typed(["string", "null"], "What the replay expected; null where it made no guess."),
            "wanted": _typed(["string", "null"], "What this network's verdicts want; null where they say nothing."),
            "ok": _typed(["boolean", "null"], "Whether the outcome is the one wanted; null where none is."),
        },
        "A replayed scene driven by this network's machines (mlca-sim replay --json), judged.",
    )


def network_evidence_schema() -> JsonObject:
    """The schema of a network's `evidence.json` (`mlca-verify evidence NETWORK.toml --out DIR`)."""
    properties: dict[str, JsonObject] = {
        **_bundle_head("network", _network_part()),
        "inputs": _array(_file("An input."), "The network spec and its machine specs, with their hashes.", minItems=1),
        "proofs": _array(_ref("result", "A result."), "Every result of the network's own properties."),
        "vehicles": _array(_vehicle(), "Each machine at each set of params its instances run with.", minItems=1),
        "code": _array(_machine_code(), "Each machine's generated code.", minItems=1),
        "closed_loop": _array(_v2v_loop(), "The closed-loop runs of each machine's code (--db; empty without)."),
        "replays": {
            "description": "The replayed scenes of network counterexamples (--replay); null without.",
            "anyOf": [{"type": "null"}, _array(_scene(), "The scenes driven by these machines.")],
        },
        "argument": _array(_argument(), "The argument's nodes, the top goal first.", minItems=1),
    }
    return _document(
        "network-evidence",
        "What `mlca-verify evidence NETWORK.toml --out DIR` writes as DIR/evidence.json: the network's goals, each "
        "vehicle's, the channels, each machine's code, the closed loop and the replays, and a GSN-style argument.",
        properties,
        {**_check_defs(networks=True), "result": _result(timed=False)},
    )


# --- the shipped files ----------------------------------------------------------------------------------------


BUILDERS = {
    "check": check_schema,
    "conform": conform_schema,
    "tests": tests_schema,
    "evidence": evidence_schema,
    "network-evidence": network_evidence_schema,
}


def file_name(report: str) -> str:
    """The shipped file of `report`'s schema: check-3.schema.json for mlca-verify.check/3."""
    kind, version = REPORTS[report].removeprefix("mlca-verify.").split("/")
    return f"{kind}-{version}.schema.json"


def report_schema(report: str) -> JsonObject:
    """The JSON Schema of `report` (a key of REPORTS)."""
    return BUILDERS[report]()


def schema_text(report: str) -> str:
    """The schema as the package ships it (mlca_verify/schemas/<file_name(report)>)."""
    return json.dumps(report_schema(report), indent=2, ensure_ascii=True) + "\n"
