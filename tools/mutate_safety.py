"""A mutation check of the safety tests: does the suite notice a deliberately broken copy of the code?

Issue 51, item 8. Each mutant changes one operator or constant of one module of `hrc_drake/safety`
(a comparison flipped, + for -, * for /, and for or, a number doubled or zeroed, True for False,
`not` dropped), in a separate git worktree of HEAD, and runs the safety tests there; a mutant the
tests fail on is killed, one they pass on survives (it is listed, to be killed by a new test or
shown equivalent). Mutants are drawn with a seed from every candidate site, so a run of N is a
sample whose killed share estimates the whole.

    python tools/mutate_safety.py --mutants 60          # ~1 minute a mutant on 2 cores
    python tools/mutate_safety.py --quick                # 3 mutants of judge.py: the tool works

Last line: one JSON object with `mutation.safety.killed_pct`, `mutation.safety.mutants`,
`mutation.safety.killed`, `mutation.safety.survivors` (file, line, what changed).
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
MODULES = ("judge.py", "verdict.py", "ssm.py", "limits.py", "rules.py", "regions.py", "systems.py")
TESTS = ("tests/safety",)
_SWAPS = {ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt, ast.Eq: ast.NotEq,
          ast.NotEq: ast.Eq, ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult,
          ast.And: ast.Or, ast.Or: ast.And}


def sites(tree: ast.AST) -> list[tuple[ast.AST, str]]:
    """Every node a mutant may change, with the kind of change, in a fixed (walk) order; docstrings
    and the numbers of defaults in signatures are left alone."""
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef)) and node.body
                  and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare) and type(node.ops[0]) in _SWAPS:
            out.append((node, "compare"))
        elif isinstance(node, ast.BinOp) and type(node.op) in _SWAPS:
            out.append((node, "binop"))
        elif isinstance(node, ast.BoolOp) and type(node.op) in _SWAPS:
            out.append((node, "boolop"))
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            out.append((node, "not"))
        elif isinstance(node, ast.Constant) and id(node) not in docstrings:
            if isinstance(node.value, bool):
                out.append((node, "bool"))
            elif isinstance(node.value, (int, float)) and node.value != 0:
                out.append((node, "number"))
    return out


class _Mutate(ast.NodeTransformer):
    def __init__(self, target):
        self.target = target
        self.change = ""

    def generic_visit(self, node):
        node = super().generic_visit(node)
        if node is not self.target:
            return node
        if isinstance(node, ast.Compare):
            old = type(node.ops[0])
            node.ops[0] = _SWAPS[old]()
            self.change = f"{old.__name__} -> {type(node.ops[0]).__name__}"
        elif isinstance(node, (ast.BinOp, ast.BoolOp)):
            old = type(node.op)
            node.op = _SWAPS[old]()
            self.change = f"{old.__name__} -> {type(node.op).__name__}"
        elif isinstance(node, ast.UnaryOp):
            self.change = "not dropped"
            return node.operand
        elif isinstance(node.value, bool):
            self.change = f"{node.value} -> {not node.value}"
            node.value = not node.value
        else:
            new = node.value * 2 if isinstance(node.value, float) else node.value + 1
            self.change = f"{node.value!r} -> {new!r}"
            node.value = new
        return node


def mutant(source: str, index: int) -> tuple[str, int, str]:
    """(mutated source, line, change) of the index-th site of `source`."""
    tree = ast.parse(source)
    node, _ = sites(tree)[index]
    line = node.lineno
    transformer = _Mutate(node)
    tree = transformer.visit(tree)
    return ast.unparse(ast.fix_missing_locations(tree)), line, transformer.change


def run_tests(workdir: Path, timeout: float) -> bool:
    """Whether the safety tests pass in `workdir` (a mutant that hangs them counts as killed)."""
    command = [sys.executable, "-m", "pytest", "-x", "-q", "-m", "not slow", "-p", "no:cacheprovider", *TESTS]
    try:
        environment = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1",
                       "NUMBA_CACHE_DIR": str(workdir / ".numba")}
        done = subprocess.run(command, cwd=workdir, capture_output=True, timeout=timeout, env=environment)
    except subprocess.TimeoutExpired:
        return False
    return done.returncode == 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mutants", type=int, default=60, help="how many mutants to draw")
    parser.add_argument("--seed", type=int, default=51)
    parser.add_argument("--modules", default=",".join(MODULES), help="modules of hrc_drake/safety")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds a test run may take")
    parser.add_argument("--quick", action="store_true", help="3 mutants of judge.py")
    parser.add_argument("--sites", default="",
                        help="only these mutants, e.g. judge.py:123,rules.py:40 (a survivor's `site`)")
    args = parser.parse_args()
    modules = ("judge.py",) if args.quick else tuple(args.modules.split(","))
    count = 3 if args.quick else args.mutants
    candidates = []
    for name in modules:
        source = (REPO / "hrc_drake" / "safety" / name).read_text()
        candidates += [(name, k) for k in range(len(sites(ast.parse(source))))]
    rng = np.random.default_rng(args.seed)
    chosen = [candidates[i] for i in sorted(rng.choice(len(candidates), size=min(count, len(candidates)),
                                                        replace=False))]
    if args.sites:
        chosen = [(name, int(index)) for name, index in (s.split(":") for s in args.sites.split(","))]
    work = Path(tempfile.mkdtemp(prefix="mutate_safety_"))
    tree = work / "tree"
    subprocess.run(["git", "worktree", "add", "--detach", str(tree), "HEAD"], cwd=REPO, check=True,
                   capture_output=True)
    killed, survivors = 0, []
    try:
        if not run_tests(tree, args.timeout):
            raise SystemExit("the safety tests fail on HEAD itself: no mutation check")
        for n, (name, index) in enumerate(chosen, 1):
            path = tree / "hrc_drake" / "safety" / name
            original = path.read_text()
            text, line, change = mutant(original, index)
            path.write_text(text)
            try:
                caught = not run_tests(tree, args.timeout)
            finally:
                path.write_text(original)
            killed += caught
            if not caught:
                survivors.append({"file": name, "line": line, "change": change, "site": f"{name}:{index}"})
            print(f"{n:3d}/{len(chosen)} {name}:{line} {change:24s} {'killed' if caught else 'SURVIVED'}"
                  f" (site {name}:{index})", flush=True)
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=REPO, capture_output=True)
        shutil.rmtree(work, ignore_errors=True)
    share = 100.0 * killed / max(len(chosen), 1)
    print(f"killed {killed} of {len(chosen)} mutants ({share:.1f} %); {len(survivors)} survived")
    print(json.dumps({"mutation.safety.killed_pct": round(share, 1), "mutation.safety.mutants": len(chosen),
                      "mutation.safety.killed": killed, "mutation.safety.survivors": survivors}))


if __name__ == "__main__":
    main()
