"""Mutation gate of the bolt: break it on purpose and see which tests notice.

    .venv/bin/python scripts/mutate_bolt.py                 # the gate: every mutation
    .venv/bin/python scripts/mutate_bolt.py --check         # each still applies (nothing run)
    .venv/bin/python scripts/mutate_bolt.py --list          # the mutations, nothing run
    .venv/bin/python scripts/mutate_bolt.py tests/wrappers  # other test paths for all

A mutation finds the code it breaks by what the code *is*, not where it sits: the function
that holds it (``BoltEngine._step``) and an expression or statement compared by its syntax
tree, so moving lines, reformatting or renaming elsewhere never unhooks it; only changing
that code does, and then ``--check`` (and ``tests/test_mutation_gate.py`` in the default
suite) says which mutation no longer applies, so the gate cannot rot unnoticed.

Each mutation is applied to a *copy* of the repository (``src``, ``tests`` and
``pyproject.toml`` in a temporary directory, imported first through ``PYTHONPATH``),
never to the working tree, so it is safe beside other work. The tests that should catch
it (its own ``tests``, or the paths given) run on the copy with ``-m "not slow"`` and stop
at the first failure; a mutation no test notices is a hole in the suite. The table goes to
stdout as Markdown; the exit status is 1 if some mutation survived or could not be
applied, 2 if the unmutated tests fail.
"""

from __future__ import annotations

import argparse
import ast
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


class MutationNotAppliedError(Exception):
    """The code a mutation targets is not found (once) where it says: the source moved on,
    and the mutation must follow it."""


@dataclass(frozen=True)
class Mutation:
    """One deliberate bug: in ``function`` of ``path``, the code ``old`` becomes ``new``.

    Attributes:
        name: what the bug does, in the table.
        path: the file, relative to the repository.
        function: the qualified name of the function holding the code
            (``"BoltEngine._step"``, ``"progress_potential"``).
        old: an expression or statement, found by its syntax tree (layout and comments
            do not matter); it must occur exactly once in the function unless ``every``.
        new: what replaces it (an expression is put in parentheses).
        tests: the test files that should catch it (run by the gate).
        every: replace every occurrence in the function (at least one).
    """

    name: str
    path: str
    function: str
    old: str
    new: str
    tests: tuple[str, ...]
    every: bool = False

    def apply(self, source: str) -> str:
        """``source`` with the mutation applied.

        Raises:
            MutationNotAppliedError: the function or the code is not found (or found more than
                once without ``every``), or the result is not Python.
        """
        tree = ast.parse(source)
        function = _find_function(tree, self.function)
        if function is None:
            raise MutationNotAppliedError(f"{self.path}: no function {self.function}")
        target, kind = _parse_fragment(self.old)
        wanted = ast.dump(target)
        found = [
            n
            for n in ast.walk(function)
            if isinstance(n, kind) and n is not function and ast.dump(n) == wanted
        ]
        if not found or (len(found) > 1 and not self.every):
            raise MutationNotAppliedError(
                f"{self.path}: {self.old!r} found {len(found)} times in {self.function}, "
                f"not {'at least' if self.every else 'exactly'} once"
            )
        # The nodes' columns count UTF-8 bytes: splice the bytes.
        data = source.encode()
        offsets = _line_offsets(data)
        spans = sorted(
            (
                offsets[n.lineno - 1] + n.col_offset,  # type: ignore[attr-defined]
                offsets[n.end_lineno - 1] + n.end_col_offset,  # type: ignore[attr-defined]
            )
            for n in found
        )
        replacement = (f"({self.new})" if kind is ast.expr else self.new).encode()
        for start, end in reversed(spans):
            data = data[:start] + replacement + data[end:]
        out = data.decode()
        try:
            mutated = ast.parse(out)
        except SyntaxError as error:
            raise MutationNotAppliedError(
                f"{self.path}: the mutated code is not Python ({error})"
            ) from None
        if ast.dump(mutated) == ast.dump(tree):
            raise MutationNotAppliedError(f"{self.path}: {self.new!r} changes nothing")
        return out


def _find_function(tree: ast.AST, qualified: str) -> ast.AST | None:
    node: ast.AST | None = tree
    for part in qualified.split("."):
        children = [] if node is None else ast.iter_child_nodes(node)
        node = next(
            (
                c
                for c in children
                if isinstance(c, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef)
                and c.name == part
            ),
            None,
        )
    return node


def _parse_fragment(code: str) -> tuple[ast.AST, type[ast.AST]]:
    """The node of an expression (``ast.expr``) or a single statement (``ast.stmt``)."""
    try:
        return ast.parse(code, mode="eval").body, ast.expr
    except SyntaxError:
        body = ast.parse(code).body
        if len(body) != 1:
            raise ValueError(
                f"a mutation's code is one expression or statement: {code!r}"
            ) from None
        return body[0], ast.stmt


def _line_offsets(data: bytes) -> list[int]:
    """The byte offset at which each line starts (lines as ``ast`` counts them)."""
    offsets, total = [], 0
    for line in data.splitlines(keepends=True):
        offsets.append(total)
        total += len(line)
    offsets.append(total)
    return offsets


_ENGINE = "src/noisybolt/bolt/engine.py"
_BOLT = "src/noisybolt/bolt/restraining_bolt.py"
_SCHEMES = "src/noisybolt/bolt/schemes.py"
_SHAPING = "src/noisybolt/bolt/shaping.py"
_BELIEF = "src/noisybolt/bolt/belief.py"
_BY_HAND = "tests/wrappers/test_bolt_reward_by_hand.py"
_ENGINE_TESTS = (_BY_HAND, "tests/bolt/test_bolt_engine.py")
_SCHEME_TESTS = ("tests/bolt/test_reward_schemes.py", "tests/bolt/test_bolt_api.py", _BY_HAND)
_BELIEF_TESTS = ("tests/bolt/test_belief.py",)

MUTATIONS: tuple[Mutation, ...] = (
    # ---------------------------------------------------------------- Algorithm 1
    Mutation(
        "truth threshold: p > 0.5 instead of p >= 0.5",
        _ENGINE,
        "BoltEngine._step",
        "probs >= self._thresholds.truth",
        "probs > self._thresholds.truth",
        _ENGINE_TESTS,
    ),
    Mutation(
        "low-confidence threshold: p < 0.9 instead of p <= 0.9",
        _ENGINE,
        "BoltEngine._step",
        "probs <= self._thresholds.high",
        "probs < self._thresholds.high",
        _ENGINE_TESTS,
    ),
    Mutation(
        "low-confidence band flipped: the high band is charged",
        _ENGINE,
        "BoltEngine._step",
        "probs <= self._thresholds.high",
        "probs > self._thresholds.high",
        _ENGINE_TESTS,
    ),
    Mutation(
        "cost sign (count mode): a low-confidence fluent pays",
        _ENGINE,
        "BoltEngine._step",
        "0.0 - n_low * self._cost",
        "0.0 + n_low * self._cost",
        _ENGINE_TESTS,
    ),
    Mutation(
        "cost sign (proportional mode): a low-confidence fluent pays",
        _ENGINE,
        "BoltEngine._step",
        "0.0 - scaled * self._cost",
        "0.0 + scaled * self._cost",
        _ENGINE_TESTS,
    ),
    Mutation(
        "reward timing: on_entry pays on every accepting step",
        _ENGINE,
        "BoltEngine.terminal_rewards",
        "self._on_entry & entered",
        "self._on_entry",
        _ENGINE_TESTS,
    ),
    Mutation(
        "reward timing: the first transition is no entry",
        _ENGINE,
        "BoltEngine._step",
        "self._accepting_flat[states + self._state_offsets] & ~first[:, None]",
        "self._accepting_flat[states + self._state_offsets]",
        _ENGINE_TESTS,
    ),
    Mutation(
        "reward timing: episode_end pays before the episode ends",
        _ENGINE,
        "BoltEngine.terminal_rewards",
        "self._episode_end & ended[:, None]",
        "self._episode_end",
        _ENGINE_TESTS,
    ),
    Mutation(
        "reward timing: the reset transition's reward is not carried",
        _BOLT,
        "RestrainingBolt.step",
        "out._replace(carried=carried, total=out.total + carried)",
        "out._replace(carried=carried, total=out.total)",
        (_BY_HAND, "tests/bolt/test_restraining_bolt.py"),
        every=True,  # under threshold and belief tracking alike
    ),
    Mutation(
        "DFA next state: the DFA never moves",
        _ENGINE,
        "BoltEngine._transition",
        "self._flat_next[cells]",
        "states.copy()",
        _ENGINE_TESTS,
    ),
    Mutation(
        "DFA next state: the edge of the letter with its first fluent flipped",
        _ENGINE,
        "BoltEngine._transition",
        "self._flat_next[cells]",
        "self._flat_next[cells ^ 1]",
        _ENGINE_TESTS,
    ),
    # ---------------------------------------------------------------- compliance payments
    Mutation(
        "compliance: a spec pays its own terminal reward, not the scheme's scale",
        _SCHEMES,
        "RewardScheme.apply",
        "float(value)",
        "spec.terminal_reward",
        _SCHEME_TESTS,
    ),
    Mutation(
        "compliance: pay_on_change pays at the episode's end (timings swapped)",
        _SCHEMES,
        "RewardScheme.apply",
        "'on_change' if self.pay_on_change else 'episode_end'",
        "'episode_end' if self.pay_on_change else 'on_change'",
        _SCHEME_TESTS,
    ),
    Mutation(
        "compliance: the scale is the returns' width, without the margin",
        _SCHEMES,
        "compliance_scale",
        "COMPLIANCE_MARGIN * bounds.width",
        "bounds.width",
        _SCHEME_TESTS,
    ),
    Mutation(
        "compliance (on_change): acceptance lost is not taken back",
        _ENGINE,
        "BoltEngine.terminal_rewards",
        "self._on_change & lost",
        "self._on_change & False",
        _SCHEME_TESTS,
    ),
    Mutation(
        "compliance (on_change): the episode's first transition is paid",
        _ENGINE,
        "BoltEngine.terminal_rewards",
        "self._on_change & gained & later",
        "self._on_change & gained",
        _SCHEME_TESTS,
    ),
    # ---------------------------------------------------------------- progress shaping
    Mutation(
        "shaping: the potential rises with the distance to acceptance",
        _SHAPING,
        "progress_potential",
        "-scale * distance / (d_max + 1)",
        "scale * distance / (d_max + 1)",
        _SCHEME_TESTS,
    ),
    Mutation(
        "shaping: the next state's potential is paid at the episode's end too",
        _SHAPING,
        "ProgressShaping.__call__",
        "np.where(ended, 0.0, self._gamma * after)",
        "self._gamma * after",
        _SCHEME_TESTS,
    ),
    Mutation(
        "shaping: entering a state that cannot accept is paid, not charged",
        _SHAPING,
        "ProgressShaping.__call__",
        "self._dead_cost[cells] - self._dead_cost[next_cells]",
        "self._dead_cost[next_cells] - self._dead_cost[cells]",
        _SCHEME_TESTS,
    ),
    # ---------------------------------------------------------------- the constraint's cost
    Mutation(
        "constraint: an episode's cost counts the specs it satisfies",
        "src/noisybolt/bolt/constraint.py",
        "episode_costs",
        "(~accepting).sum(axis=1)",
        "accepting.sum(axis=1)",
        ("tests/bolt/test_constraint.py",),
    ),
    Mutation(
        "constraint: the price rises while the cost is under the budget",
        "src/noisybolt/bolt/constraint.py",
        "LagrangeMultiplier.update",
        "self._integral + step",
        "self._integral - step",
        ("tests/bolt/test_constraint.py",),
    ),
    # ---------------------------------------------------------------- belief tracking
    Mutation(
        "belief update: the detector's evidence is ignored (prediction only)",
        _BELIEF,
        "BeliefEngine.step_joint",
        "self._observe(np.matmul(joint, self._move), probs)",
        "np.matmul(joint, self._move)",
        _BELIEF_TESTS,
    ),
    Mutation(
        "belief update: the DFA and the fluents never move (no prediction)",
        _BELIEF,
        "BeliefEngine.step_joint",
        "np.matmul(joint, self._move)",
        "joint",
        _BELIEF_TESTS,
    ),
    Mutation(
        "belief update: the evidence read backwards (p as 1 - p)",
        _BELIEF,
        "BeliefEngine._evidence",
        "np.log(p) - np.log1p(-p) - self._model.prior_logit",
        "np.log1p(-p) - np.log(p) - self._model.prior_logit",
        _BELIEF_TESTS,
    ),
)


def check_mutations(
    mutations: Sequence[Mutation] = MUTATIONS, root: Path = ROOT
) -> dict[str, str | None]:
    """Each mutation's name -> None where it applies to the sources under ``root``, else
    why not (nothing is written or run)."""
    out: dict[str, str | None] = {}
    for m in mutations:
        try:
            m.apply((root / m.path).read_text())
            out[m.name] = None
        except MutationNotAppliedError as error:
            out[m.name] = str(error)
    return out


def _copy_repository(into: Path) -> None:
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".pytest_cache", "*.egg-info")
    for name in ("src", "tests"):
        shutil.copytree(ROOT / name, into / name, ignore=ignore)
    shutil.copy2(ROOT / "pyproject.toml", into / "pyproject.toml")


def _run_tests(copy: Path, targets: Sequence[str]) -> tuple[int, str]:
    env = {**os.environ, "PYTHONPATH": str(copy / "src")}
    command = [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider"]
    command += ["-p", "no:randomly", "-n", "0", "-m", "not slow", *targets]
    proc = subprocess.run(command, cwd=copy, env=env, capture_output=True, text=True)
    failed = re.findall(r"^FAILED (\S+)", proc.stdout, flags=re.MULTILINE)
    last = proc.stdout.strip().splitlines()[-1:] or proc.stderr.strip().splitlines()[-1:]
    return proc.returncode, failed[0] if failed else " ".join(last)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("targets", nargs="*", help="test paths for every mutation")
    parser.add_argument("--list", action="store_true", help="print the mutations and stop")
    parser.add_argument("--check", action="store_true", help="check that each applies, run nothing")
    parser.add_argument("-k", default="", help="only the mutations whose name holds this")
    args = parser.parse_args(argv)
    mutations = [m for m in MUTATIONS if args.k in m.name]
    if args.list:
        for m in mutations:
            print(f"{m.name}\n    {m.path} {m.function}: {m.old!r} -> {m.new!r}")
        return 0
    problems = check_mutations(mutations)
    if args.check:
        for name, problem in problems.items():
            print(f"{'applies' if problem is None else 'NOT APPLIED'}: {name}"
                  + (f" ({problem})" if problem else ""))  # fmt: skip
        return 1 if any(problems.values()) else 0

    holes = 0
    with tempfile.TemporaryDirectory(prefix="mutate-bolt-") as tmp:
        copy = Path(tmp)
        _copy_repository(copy)
        probe = subprocess.run(
            [sys.executable, "-c", "import noisybolt; print(noisybolt.__file__)"],
            cwd=copy,
            env={**os.environ, "PYTHONPATH": str(copy / "src")},
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        if not probe.startswith(str(copy)):
            print(f"error: the copy is not the package imported ({probe})", file=sys.stderr)
            return 2
        every_target = sorted({t for m in mutations for t in (args.targets or m.tests)})
        code, summary = _run_tests(copy, every_target)
        if code != 0:
            print(f"error: the unmutated tests fail: {summary}", file=sys.stderr)
            return 2
        print("| mutation | function | applied | caught by (first failing test) | s |")
        print("|---|---|---|---|---|")
        for m in mutations:
            if problems[m.name] is not None:
                holes += 1
                print(f"| {m.name} | {m.function} | NO: {problems[m.name]} | - | - |")
                continue
            path = copy / m.path
            original = path.read_text()
            path.write_text(m.apply(original))
            try:
                start = time.monotonic()
                code, summary = _run_tests(copy, args.targets or m.tests)
                seconds = time.monotonic() - start
            finally:
                path.write_text(original)
            caught = code != 0
            holes += not caught
            verdict = summary if caught else f"SURVIVED ({summary})"
            print(f"| {m.name} | {m.function} | yes | {verdict} | {seconds:.0f} |", flush=True)
    return 1 if holes else 0


if __name__ == "__main__":
    sys.exit(main())
