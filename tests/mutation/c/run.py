"""Mutation testing of the project's C (docs/mutation.md, "The C").

    python tests/mutation/c/run.py [--sample N] [--seed S] [--files F ...] [--results R.jsonl]
                                   [--scratch DIR] [--gen DIR] [--shard K/N]
    python tests/mutation/c/run.py --score R.jsonl [--survivors]
    python tests/mutation/c/run.py --full R.jsonl          # survivors of the subset on the full files
    python tests/mutation/c/run.py --since REV ...         # only mutants of lines changed since REV

Mutants are made by universalmutator (PyPI; ``mutate FILE c --noCheck``: every rule of its
C and generic rule sets, one change per mutant) for the files of config.toml. A run draws a
sample stratified by file: each file's mutants are shuffled with the seed and the files are
interleaved in proportion to their mutant counts, so that any prefix of the run is spread
over the files like the whole (a run stopped early is still a fair sample; the same seed
gives the same order). For each mutant, one at a time:

1. the mutant is written into a scratch copy of the checkout (``--scratch``, default
   /tmp/cmut: the committed tree of HEAD, never the working copy), and what the tests load is
   rebuilt from it: the kernel (``python setup.py build_ext --inplace``), the native FMUs the
   file goes into, and for the kernel the pythonfmu FMUs that bundle it. A mutant the
   project's build refuses (a compile error, or a warning at -Wall -Wextra, which the native
   build treats as an error) is discarded, not counted;
2. it is judged by the file's fast subset (``pytest -x -k "<fast_k>"``, BALLMILL_TEST_FMU_DIR
   pointing at the rebuilt FMUs), with a limit on the CPU time its processes use (config.toml):
   a failing test, a crashed test process or the limit kills it (the kernel's mutants meet
   the tests that load no FMU first, on the rebuilt kernel alone);
3. the tree and the FMUs are restored.

Every verdict is appended at once to the results file (JSONL), with the commit whose tests
judged it, so that a run stopped at any point gives a score. A re-run with the same results
file skips the mutants it already has. ``--score`` counts them, with the mutants of
equivalent.toml (each with its reason) apart; ``--full`` runs the subset's survivors (the equivalent ones too) on
the file's full list of test files (config.toml) and records that verdict too; ``--ids``
judges the given mutants again (after new tests: the newest verdict counts). A mutant's
number counts the file's mutants as the file is now (a change above it can renumber it): a
run refuses a results file that records a mutant it would judge or skip with another change
(drawn on other C: judge it from a checkout of that C).
"""
from __future__ import annotations

import argparse
import difflib
import hashlib
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
CONFIG = HERE / "config.toml"
EQUIVALENT = HERE / "equivalent.toml"
MODELS = ("BallInShell", "MotorStartup", "InductionMotor", "Structure", "Fig1Drive")


def config() -> dict:
    return tomllib.loads(CONFIG.read_text())


def sh(cmd, cwd=None, env=None, timeout=None, capture=True):
    """Run cmd in its own process group at nice 10; (returncode or 'timeout', output)."""
    code, out, _ = sh_limited(cmd, cwd, env, timeout, None, capture)
    return code, out


CLK_TCK = os.sysconf("SC_CLK_TCK")


def session_cpu(sid: int) -> float:
    """CPU seconds (user + system) used so far by the live processes of session sid, with the
    children they have waited for."""
    ticks = 0
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as f:
                stat = f.read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if int(fields[3]) == sid:
            ticks += sum(int(x) for x in fields[11:15])
    return ticks / CLK_TCK


def sh_limited(cmd, cwd=None, env=None, timeout=None, cpu_limit=None, capture=True):
    """sh with a limit on the CPU time the command's session uses (it and every process it
    starts, polled each second) as well as on the wall-clock time: on a loaded machine a test
    process gets a fraction of a core, and a wall-clock limit alone would stop slow runs as if
    they never ended. (returncode or 'timeout', output, CPU seconds used)."""
    import resource
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.Popen(["nice", "-n", "10", *cmd], cwd=cwd, env=env, start_new_session=True,
                            stdout=subprocess.PIPE if capture else None, stderr=subprocess.STDOUT,
                            text=True)
    t0, cpu = time.monotonic(), 0.0
    while True:
        try:
            out, _ = proc.communicate(timeout=1.0)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = max(cpu, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
            return proc.returncode, out or "", cpu
        except subprocess.TimeoutExpired:
            cpu = max(cpu, session_cpu(proc.pid))
            if (timeout is not None and time.monotonic() - t0 > timeout) or (cpu_limit is not None and cpu > cpu_limit):
                os.killpg(proc.pid, signal.SIGKILL)
                out, _ = proc.communicate()
                return "timeout", out or "", cpu


# ----------------------------------------------------------------------------- mutants
# universalmutator (1.14.1) scans every language for Haskell's block comments: from a line
# holding "{-" it skips every line up to one holding "-}", which in C is the rest of the file
# (an initialiser such as {{5.0, 8.0, -1.0}, {-1.0, 8.0, 5.0}} left three quarters of the kernel
# without a mutant). It is given a copy with "{ -" there; each mutant then gets the original's
# text back on the lines it does not change.
HASKELL_COMMENT = "{-"


def _unhide(original: list[str], hidden: list[str], lines: list[str]) -> list[str]:
    """A mutant of the copy `hidden` as a mutant of `original` (the same lines, one to one)."""
    back = [m.replace("{ -", HASKELL_COMMENT) for m in lines]  # the changed lines as the original writes them
    if len(lines) == len(hidden):
        return [o if m == h else b for o, h, m, b in zip(original, hidden, lines, back)]
    out = []
    for op, i1, i2, j1, j2 in difflib.SequenceMatcher(a=hidden, b=lines, autojunk=False).get_opcodes():
        out += original[i1:i2] if op == "equal" else back[j1:j2]
    return out


def generate(rel: str, gen: Path) -> list[dict]:
    """Every mutant of the checkout's file `rel`: [{id, file, line, before, after, path}].
    Cached under gen/<file>-<file's sha256>/ (a changed file gets new mutants)."""
    src = ROOT / rel
    digest = hashlib.sha256(src.read_bytes()).hexdigest()[:16]
    text = src.read_text()
    hide = HASKELL_COMMENT in text
    # (a file with "{-" was cut short before this copy: its folder gets another name)
    out = gen / f"{rel.replace('/', '_')}-{digest}{'-whole' if hide else ''}"
    done = out / "DONE"
    if not done.exists():
        # shards share gen/: each generates into its own folder and renames it into place
        # (atomic); a shard that loses the race keeps the winner's identical mutants
        tmp = out.with_name(f"{out.name}.tmp{os.getpid()}")
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir(parents=True)
        target = src
        if hide:
            target = out.with_name(f"{out.name}.src{os.getpid()}") / src.name
            shutil.rmtree(target.parent, ignore_errors=True)
            target.parent.mkdir(parents=True)
            target.write_text(text.replace(HASKELL_COMMENT, "{ -"))
        code, log = sh(["mutate", str(target), "c", "--noCheck", "--mutantDir", str(tmp)])
        if code != 0:
            raise SystemExit(f"universalmutator failed on {rel} (exit {code}):\n{log[-2000:]}")
        if hide:
            original, hidden = text.splitlines(), target.read_text().splitlines()
            for path in tmp.glob(f"{src.stem}.mutant.*{src.suffix}"):
                path.write_text("\n".join(_unhide(original, hidden, path.read_text().splitlines())) + "\n")
            shutil.rmtree(target.parent, ignore_errors=True)
        (tmp / "DONE").write_text(log)
        try:
            tmp.rename(out)
        except OSError:  # another shard's folder is there first
            shutil.rmtree(tmp, ignore_errors=True)
    listing = out / "mutants.json"
    if listing.exists():
        return json.loads(listing.read_text())
    original = src.read_text().splitlines()
    stem = src.stem
    mutants = []
    for path in out.glob(f"{stem}.mutant.*{src.suffix}"):
        number = int(path.name[len(stem) + len(".mutant."):-len(src.suffix)])
        lines = path.read_text().splitlines()
        if lines == original:
            continue
        if len(lines) == len(original):  # universalmutator rewrites one line in place (fast path)
            diff = [i for i, (a, b) in enumerate(zip(original, lines)) if a != b]
            i1, i2, j1, j2 = diff[0], diff[-1] + 1, diff[0], diff[-1] + 1
        else:
            sm = difflib.SequenceMatcher(a=original, b=lines, autojunk=False)
            _, i1, i2, j1, j2 = next(op for op in sm.get_opcodes() if op[0] != "equal")
        mutants.append(dict(id=f"{rel}:{number}", file=rel, line=i1 + 1,
                            before="\n".join(original[i1:i2]), after="\n".join(lines[j1:j2]),
                            path=str(path)))
    mutants.sort(key=lambda m: int(m["id"].rsplit(":", 1)[1]))
    part = listing.with_name(f"mutants.json.tmp{os.getpid()}")
    part.write_text(json.dumps(mutants))
    part.replace(listing)
    return mutants


def changed_lines(rel: str, since: str, root: Path = ROOT) -> set[int]:
    """The lines (1-based, of HEAD's file `rel`) that HEAD adds or rewrites since revision `since`:
    the new side of every hunk of ``git diff -U0 since HEAD -- rel``. A file that did not exist at
    `since` (or was renamed since: the diff is limited to the path) counts as new in full; lines
    only deleted leave nothing to mutate."""
    proc = subprocess.run(["git", "-C", str(root), "diff", "--no-ext-diff", "--no-color", "-U0", since, "HEAD",
                           "--", rel], capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"git diff {since} HEAD -- {rel} failed: {proc.stderr.strip()}")
    lines: set[int] = set()
    for hunk in re.finditer(r"^@@ -\d+(?:,\d+)? \+(\d+)(?:,(\d+))? @@", proc.stdout, re.M):
        start, count = int(hunk.group(1)), int(hunk.group(2) or 1)
        lines.update(range(start, start + count))
    return lines


def stratified(files: list[str], gen: Path, seed: int) -> list[dict]:
    """All mutants of the files in the run's order: each file's shuffled with the seed, the
    files interleaved in proportion to their counts (the k-th of n at (k + 1/2) / n)."""
    keyed = []
    for rel in files:
        ms = generate(rel, gen)
        random.Random(f"{seed}:{rel}").shuffle(ms)
        keyed += [((k + 0.5) / len(ms), rel, m) for k, m in enumerate(ms)]
    keyed.sort(key=lambda x: (x[0], x[1]))
    return [m for _, _, m in keyed]


def drawn_elsewhere(order: list[dict], done: dict) -> list[str]:
    """The mutants of `order` that the results file `done` records with another change (the text
    before and after; a line that only moved is the same change): the file was drawn on other
    C. A mutant's number counts the universalmutator mutants of the file as it is now, so a
    change above it can shift the numbers and the same id then names another change."""
    out = []
    for m in order:
        r = done.get(m["id"])
        if r and (r.get("before"), r.get("after")) != (m["before"], m["after"]):
            out.append(f"{m['id']} is recorded as {str(r.get('after')).strip()!r} (line {r.get('line')}), "
                       f"here {m['after'].strip()!r} (line {m['line']})")
    return out


# ----------------------------------------------------------------------------- the scratch tree
class Scratch:
    """scratch/tree: HEAD's committed tree with the kernel built; scratch/fmus_ref: both
    flavours built from it; scratch/fmus: what the tests load (the reference, plus the
    artifacts of the mutant under test)."""

    def __init__(self, root: Path):
        self.root = root
        self.tree = root / "tree"
        self.ref = root / "fmus_ref"
        self.fmus = root / "fmus"
        self.pristine = root / "pristine"
        self.commit = ""

    def env(self) -> dict:
        env = dict(os.environ, PYTHONPATH=str(self.tree), BALLMILL_TEST_FMU_DIR=str(self.fmus),
                   PYTHONDONTWRITEBYTECODE="1")
        env.pop("MUTANT_UNDER_TEST", None)
        return env

    def head(self) -> str:
        return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()

    def built_from(self, commit: str) -> str:
        """What the reference builds depend on at commit: its tree less tests/ and docs/ (a
        commit of tests only keeps the scratch tree; sync_tests brings the tests)."""
        listing = subprocess.run(["git", "-C", str(ROOT), "ls-tree", commit], capture_output=True,
                                 text=True, check=True).stdout
        return "\n".join(ln for ln in listing.splitlines() if not ln.endswith(("\ttests", "\tdocs")))

    def setup(self, files: list[str]) -> None:
        head = self.head()
        stamp = self.root / "tree.commit"
        if stamp.exists() and (self.ref / "BallInShell.fmu").exists() \
                and self.built_from(stamp.read_text()) == self.built_from(head):
            self.commit = stamp.read_text()
            self.clean(files)
            self.sync_tests()
            self.reset_fmus()
            return
        self.commit = head
        print(f"scratch tree {self.tree} from {self.commit[:10]}: exporting, building the kernel and "
              "both flavours of every FMU", flush=True)
        shutil.rmtree(self.tree, ignore_errors=True)
        self.tree.mkdir(parents=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", "HEAD"], capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(self.tree)], input=archive.stdout, check=True)
        self._kernel_build(check=True)
        shutil.rmtree(self.ref, ignore_errors=True)
        code, out = sh([sys.executable, "-c", "import sys; from pathlib import Path; "
                        "from ballmill.fmi.build import build_all; "
                        "build_all(Path(sys.argv[1]), force=True, log=lambda m: None)", str(self.ref)],
                       cwd=self.tree, env=self.env())
        if code != 0:
            raise SystemExit(f"building the reference FMUs failed:\n{out[-3000:]}")
        shutil.rmtree(self.pristine, ignore_errors=True)
        self.pristine.mkdir()
        for so in (self.tree / "ballmill/physics").glob("_kernel*.so"):
            shutil.copy2(so, self.pristine / so.name)
        code, out = sh([sys.executable, "-c", "import sys; from pathlib import Path; "
                        "from ballmill.fmi import native; "
                        "[native.stage_sources(n, Path(sys.argv[1]) / n) for n in native.available()]",
                        str(self.root / "staged")], cwd=self.tree, env=self.env())
        if code != 0:
            raise SystemExit(f"staging the native sources failed:\n{out[-3000:]}")
        stamp.write_text(self.commit)
        self.reset_fmus()

    def syntax_check(self, rel: str, mutant: Path, builds: list[str]) -> tuple[bool, str]:
        """A quick screen before the build: the compiler's -fsyntax-only, warnings as errors,
        on the unit that holds the file (the kernel is checked inside ballinshell.c, which
        #includes it). Only a screen: what the build refuses is discarded all the same."""
        model = next((b.split(":", 1)[1] for b in builds if b.startswith("native:")), None)
        if model is None:
            return True, ""
        staged = self.root / "staged" / model
        tmp = self.root / "check"
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir()
        name = Path(rel).name
        shutil.copy2(mutant, tmp / name)
        unit = tmp / name
        if name == "_kernel.c":
            shutil.copy2(staged / "ballinshell.c", tmp / "ballinshell.c")
            unit = tmp / "ballinshell.c"
        cc = os.environ.get("CC") or shutil.which("cc") or "gcc"
        code, out = sh([cc, "-fsyntax-only", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off",
                        "-I", str(staged), str(unit)])
        return code == 0, out

    def clean(self, files: list[str]) -> None:
        """The C files and the kernel library as built (a run stopped mid-mutant leaves its
        mutant there), with the export's modification time (the FMUs built from them stay
        newer than their sources, so that nothing rebuilds them behind the runner's back)."""
        when = int(subprocess.run(["git", "-C", str(ROOT), "log", "-1", "--format=%ct", self.commit],
                                  capture_output=True, text=True, check=True).stdout)
        for rel in files:
            data = subprocess.run(["git", "-C", str(ROOT), "show", f"{self.commit}:{rel}"], capture_output=True,
                                  check=True).stdout
            (self.tree / rel).write_bytes(data)
            os.utime(self.tree / rel, (when, when))
        for so in (self.tree / "ballmill/physics").glob("_kernel*.so"):
            so.unlink()
        for so in self.pristine.glob("_kernel*.so"):
            shutil.copy2(so, self.tree / "ballmill/physics" / so.name)

    def reset_fmus(self) -> None:
        shutil.rmtree(self.fmus, ignore_errors=True)
        shutil.copytree(self.ref, self.fmus)

    def sync_tests(self) -> None:
        """The tests of the checkout's HEAD (a commit made during a run judges the mutants after it)."""
        head = self.head()
        if head == self.commit:
            return
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", head, "tests"], capture_output=True, check=True)
        shutil.rmtree(self.tree / "tests")
        subprocess.run(["tar", "-x", "-C", str(self.tree)], input=archive.stdout, check=True)
        self.commit = head
        print(f"tests now those of {head[:10]}", flush=True)

    def _kernel_build(self, check=False):
        code, out = sh([sys.executable, "setup.py", "build_ext", "--inplace", "--force", "-q"],
                       cwd=self.tree, env=self.env())
        # optional=True in setup.py: a kernel that does not compile leaves the install going;
        # fast.check_library says whether the library now there is a build of this source
        ok, why = sh([sys.executable, "-c", "import sys; from ballmill.physics import fast; "
                      "why = fast.check_library(fast._find_library()) if fast._find_library() else 'none'; "
                      "print(why); sys.exit(1 if why else 0)"], cwd=self.tree, env=self.env())
        if check and (code != 0 or ok != 0):
            raise SystemExit(f"the kernel does not build in {self.tree}:\n{out[-3000:]}\n{why}")
        return code == 0 and ok == 0, out + why

    def build(self, builds: list[str]) -> tuple[bool, str]:
        """Rebuild the artifacts of a mutant; (built, the compiler's words)."""
        if "kernel" in builds:
            ok, out = self._kernel_build()
            if not ok:
                return False, out
        natives = [b.split(":", 1)[1] for b in builds if b.startswith("native:")]
        natives3 = [b.split(":", 1)[1] for b in builds if b.startswith("native3:")]
        code = ("import sys; from pathlib import Path; from ballmill.fmi import native, build; "
                "d = Path(sys.argv[1]); [native.build_native(n, d) for n in sys.argv[2].split(',') if n]; "
                "[native.build_native(n, d / 'fmi3', fmi=3) for n in sys.argv[4].split(',') if n]; "
                "[build.build_one(s, d) for s in build.scripts()] if sys.argv[3] == '1' else None")
        rc, out = sh([sys.executable, "-c", code, str(self.fmus), ",".join(natives),
                      "1" if "pythonfmu" in builds else "0", ",".join(natives3)], cwd=self.tree, env=self.env())
        return rc == 0, out

    def restore(self, rel: str, builds: list[str]) -> None:
        shutil.copy2(self.pristine / rel.replace("/", "_"), self.tree / rel)
        if "kernel" in builds:
            for so in (self.tree / "ballmill/physics").glob("_kernel*.so"):
                so.unlink()
            for so in self.pristine.glob("_kernel*.so"):
                shutil.copy2(so, self.tree / "ballmill/physics" / so.name)
        for b in builds:
            if b.startswith("native:"):
                name = b.split(":", 1)[1]
                shutil.copy2(self.ref / f"{name}.fmu", self.fmus / f"{name}.fmu")
            elif b.startswith("native3:"):
                name = b.split(":", 1)[1]
                shutil.copy2(self.ref / "fmi3" / f"{name}.fmu", self.fmus / "fmi3" / f"{name}.fmu")
            elif b == "pythonfmu":
                shutil.rmtree(self.fmus / "pythonfmu")
                shutil.copytree(self.ref / "pythonfmu", self.fmus / "pythonfmu")

    def keep_originals(self, files: list[str]) -> None:
        for rel in files:
            shutil.copy2(self.tree / rel, self.pristine / rel.replace("/", "_"))

    def pytest(self, files: list[str], k: str | None, cpu_limit: float, native_only=True):
        """pytest -x on files, limited to cpu_limit CPU seconds (and 10 times that of wall-clock
        time); native_only: the native flavour only (native_only.py). (code, output, wall s, CPU s)"""
        present = [f for f in files if (self.tree / f).exists()]
        cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--tb=line", "-W", "ignore", "-x"]
        if native_only:
            cmd += ["-p", "tests.mutation.c.native_only"]
        if k:
            cmd += ["-k", k]
        t0 = time.monotonic()
        code, out, cpu = sh_limited(cmd + present, cwd=self.tree, env=self.env(), timeout=10 * cpu_limit,
                                    cpu_limit=cpu_limit)
        return code, out, time.monotonic() - t0, cpu


def verdict_of(code, out: str) -> tuple[str, str]:
    """(killed | survived | error, detail) from pytest's exit."""
    tail = [ln for ln in out.strip().splitlines() if ln.strip()]
    last = tail[-1] if tail else ""
    failed = next((ln for ln in tail if ln.startswith("FAILED") or ln.startswith("ERROR")), "")
    if code == "timeout":
        return "killed", "time limit"
    if code == 0:
        return "survived", last
    if code == 1:
        return "killed", (failed or last)[:300]
    if isinstance(code, int) and code < 0:
        return "killed", f"test process died of signal {-code}"
    return "error", f"pytest exit {code}: {last[:300]}"


def load_results(path: Path) -> dict:
    out = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                out.setdefault(r["id"], {}).update(r)
    return out


def append(path: Path, record: dict) -> None:
    with path.open("a") as f:
        f.write(json.dumps(record) + "\n")


def judge(scratch: Scratch, cfg: dict, m: dict, full: bool) -> dict:
    fcfg = cfg["files"][m["file"]]
    run = cfg["run"]
    record = dict(id=m["id"], file=m["file"], line=m["line"], before=m["before"], after=m["after"])
    shutil.copy2(m["path"], scratch.tree / m["file"])
    try:
        t0 = time.monotonic()
        built, words = scratch.syntax_check(m["file"], Path(m["path"]), fcfg["builds"])
        builds, first = fcfg["builds"], [] if full else fcfg.get("first", [])
        if built and first:  # tests that load only first_builds run before the rest is rebuilt
            built, words = scratch.build(fcfg["first_builds"])
            if built:
                t1 = time.monotonic()
                code, out, dt, cpu = scratch.pytest(first, run["fast_k"], run["cpu_limit_s"])
                t0 += time.monotonic() - t1
                record["verdict"], record["detail"] = verdict_of(code, out)
                record["test_s"], record["test_cpu_s"] = round(dt, 1), round(cpu, 1)
                if record["verdict"] != "survived":
                    record["build_s"] = round(time.monotonic() - t0, 1)
                    record["commit"] = scratch.commit
                    return record
                builds = [b for b in builds if b not in fcfg["first_builds"]]
        if built:
            built, words = scratch.build(builds)
        record["build_s"] = round(time.monotonic() - t0, 1)
        if not built:
            record.pop("verdict", None), record.pop("detail", None), record.pop("test_s", None)
            lines = words.strip().splitlines()
            why = next((ln for ln in lines if "error:" in ln or "warning:" in ln), lines[-1] if lines else "")
            record.update(verdict="not built", detail=why.strip()[:300])
            return record
        if full:
            # the full files the fast subset did not pass in full (a folder it ran with -k "not
            # forty" runs again); the pythonfmu flavour's tests only for the kernel, which its FMUs
            # bundle (for the other files they judge the unmutated Python adapters)
            kernel = "pythonfmu" in fcfg["builds"]
            ran = set() if kernel else set(fcfg["fast"] + fcfg.get("first", []))
            files = []
            for f in fcfg["full"]:
                if f not in ran:
                    files.append(f)
                elif not f.endswith(".py"):  # a folder: its files with the tests -k deselected
                    files += [str(p.relative_to(scratch.tree)) for p in sorted((scratch.tree / f).glob("test_*.py"))
                              if "def test_forty" in p.read_text()]
            code, out, dt, cpu = scratch.pytest(files, fcfg.get("full_k"), run["full_cpu_limit_s"],
                                                native_only=not kernel)
            record["full_verdict"], record["full_detail"] = verdict_of(code, out)
            record["full_s"], record["full_cpu_s"] = round(dt, 1), round(cpu, 1)
            record["full_commit"] = scratch.commit
        else:
            code, out, dt, cpu = scratch.pytest(fcfg["fast"], run["fast_k"],
                                                run["cpu_limit_s"] - record.get("test_cpu_s", 0))
            record["verdict"], record["detail"] = verdict_of(code, out)
            record["test_s"] = round(dt + record.get("test_s", 0), 1)
            record["test_cpu_s"] = round(cpu + record.get("test_cpu_s", 0), 1)
            record["commit"] = scratch.commit
        return record
    finally:
        scratch.restore(m["file"], fcfg["builds"])


# ----------------------------------------------------------------------------- the score
def equivalents() -> dict:
    if not EQUIVALENT.exists():
        return {}
    return {m["id"]: m for m in tomllib.loads(EQUIVALENT.read_text()).get("mutant", [])}


def undecided(r: dict) -> bool:
    """A verdict of the old wall-clock limit (180 s), which on a loaded machine stopped runs that
    were only slow: judged again under the CPU-time limit."""
    return r.get("detail") == "timeout"


def final_verdict(r: dict) -> str:
    if undecided(r):
        return "error"
    if r.get("verdict") in ("not built", "error", None):
        return r.get("verdict") or "not run"
    if r.get("full_verdict") == "killed":
        return "killed"
    return r["verdict"]


def discard_reason(detail: str) -> str:
    """A discarded mutant's compiler message as a kind: a warning (by its flag) or an error."""
    flag = re.search(r"\[-W(?:error=)?([A-Za-z0-9=-]+)\]", detail)
    if flag and flag.group(1) != "error":
        return f"warning -W{flag.group(1)}"
    return "compile error" if "error" in detail else "other (see the results file)"


def score(path: Path, survivors: bool, files: list[str]) -> int:
    results = load_results(path)
    eq = equivalents()
    rows, problems = {}, []
    for mid, m in eq.items():  # the list must not go stale
        r = results.get(mid)
        if r and (r.get("before"), r.get("after")) != (m.get("before"), m.get("after")):
            problems.append(f"{mid}: equivalent.toml's change is not the mutant's now ({r.get('after')!r})")
        if r and final_verdict(r) == "killed":
            problems.append(f"{mid}: listed as equivalent but killed ({r.get('detail') or r.get('full_detail')})")
    left = []
    for mid, r in results.items():
        row = rows.setdefault(r["file"], dict(killed=0, equivalent=0, survived=0, discarded=0, errors=0))
        v = final_verdict(r)
        if v == "not built":
            row["discarded"] += 1
        elif v == "error":
            row["errors"] += 1
        elif mid in eq and v != "killed":
            row["equivalent"] += 1
        elif v == "killed":
            row["killed"] += 1
        else:
            row["survived"] += 1
            left.append(r)
    print("| file | judged | killed | equivalent | not killed | score | not built (discarded) |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    tot = dict(killed=0, equivalent=0, survived=0, discarded=0, errors=0)
    for f in sorted(rows, key=lambda f: files.index(f) if f in files else 99):
        row = rows[f]
        for k in tot:
            tot[k] += row[k]
        judged = row["killed"] + row["equivalent"] + row["survived"]
        denom = row["killed"] + row["survived"]
        pct = f"{100 * row['killed'] / denom:.1f} %" if denom else "-"
        print(f"| `{f}` | {judged} | {row['killed']} | {row['equivalent']} | {row['survived']} | {pct} | {row['discarded']} |")
    judged = tot["killed"] + tot["equivalent"] + tot["survived"]
    denom = tot["killed"] + tot["survived"]
    pct = f"{100 * tot['killed'] / denom:.1f} %" if denom else "-"
    print(f"| **total** | **{judged}** | **{tot['killed']}** | **{tot['equivalent']}** | **{tot['survived']}** "
          f"| **{pct}** | **{tot['discarded']}** |")
    why = {}
    for r in results.values():
        if final_verdict(r) == "not built":
            why[discard_reason(r.get("detail", ""))] = why.get(discard_reason(r.get("detail", "")), 0) + 1
    if why:
        print("\ndiscarded (the project's build refuses them):",
              "; ".join(f"{n} {w}" for w, n in sorted(why.items(), key=lambda x: -x[1])))
    if tot["errors"]:
        print(f"\n{tot['errors']} mutant(s) whose test run errored or timed out under the old wall-clock "
              "limit (not counted): judge them again")
    if survivors:
        print(f"\nnot killed and not listed as equivalent ({len(left)}):")
        for r in sorted(left, key=lambda r: (r["file"], r["line"])):
            full = f" [full files: {r['full_verdict']}]" if "full_verdict" in r else " [full files: not run]"
            print(f"  {r['id']} line {r['line']}{full}\n    - {r['before'].strip()}\n    + {r['after'].strip()}")
    for p in problems:
        print("equivalent.toml:", p)
    return 1 if problems else 0


def main(argv=None) -> int:
    cfg = config()
    files_all = list(cfg["files"])
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sample", type=int, default=300, help="mutants to judge (built ones; default 300)")
    ap.add_argument("--seed", type=int, default=cfg["run"]["seed"])
    ap.add_argument("--files", nargs="+", default=files_all, choices=files_all)
    ap.add_argument("--results", type=Path, default=None,
                    help="JSONL of verdicts (default scratch/results-seed<S>.jsonl)")
    ap.add_argument("--scratch", type=Path, default=Path("/tmp/cmut"))
    ap.add_argument("--score", type=Path, metavar="RESULTS", help="print the score of a results file")
    ap.add_argument("--survivors", action="store_true", help="with --score: list the survivors")
    ap.add_argument("--full", type=Path, metavar="RESULTS",
                    help="run the survivors of RESULTS (equivalent ones included) on the full test files")
    ap.add_argument("--ids", nargs="+", help="judge these mutants (FILE:N) only")
    ap.add_argument("--since", metavar="REV",
                    help="only the mutants of lines HEAD adds or rewrites since revision REV (git diff REV HEAD)")
    ap.add_argument("--gen", type=Path, default=None,
                    help="where the generated mutants are cached (default scratch/gen; shards share it)")
    ap.add_argument("--shard", default="0/1", metavar="K/N",
                    help="judge every N-th mutant of the order from the K-th (N runs, each with its own "
                         "--scratch, the same --results and --gen: they stop together at --sample judged)")
    args = ap.parse_args(argv)
    if args.score:
        return score(args.score, args.survivors, files_all)
    if shutil.which("mutate") is None:
        raise SystemExit("universalmutator's `mutate` is not installed: pip install universalmutator")
    scratch = Scratch(args.scratch)
    results_path = args.full or args.results or args.scratch / f"results-seed{args.seed}.jsonl"
    done = load_results(results_path)
    order = stratified(args.files, args.gen or args.scratch / "gen", args.seed)
    if args.since:  # a subsequence of the seed's order: still stratified, the same mutant numbers
        changed = {rel: changed_lines(rel, args.since) for rel in args.files}
        order = [m for m in order if m["line"] in changed[m["file"]]]
    full = bool(args.full)
    if args.ids:
        missing = sorted(set(args.ids) - {m["id"] for m in order})
        if missing:
            raise SystemExit(f"--ids: no mutant {', '.join(missing)} among those of this run's files"
                             f"{' and lines (--since)' if args.since else ''}")
        order = [m for m in order if m["id"] in set(args.ids)]
    elif full:  # the equivalent ones too: the full files must not kill them either
        order = [m for m in order if m["id"] in done and done[m["id"]].get("verdict") == "survived"
                 and "full_verdict" not in done[m["id"]]]
    stale = drawn_elsewhere(order, done)
    if stale:
        raise SystemExit(f"{results_path} was drawn on other C than this checkout's: {len(stale)} of the mutants "
                         f"this run would judge or skip name other changes here ({stale[0]}). Judge them from a "
                         "checkout whose C is the one they were drawn on, or give a new --results")
    scratch.setup(files_all)
    scratch.keep_originals(files_all)
    k, n = (int(x) for x in args.shard.split("/"))
    order = order[k::n]
    judged = sum(1 for r in done.values() if r.get("verdict") in ("killed", "survived"))
    print(f"{len(order)} mutants in order; {judged} already judged in {results_path}", flush=True)
    for m in order:
        if not full and not args.ids:
            done = load_results(results_path)  # the other shards' verdicts too
            judged = sum(1 for r in done.values() if r.get("verdict") in ("killed", "survived") and not undecided(r))
            if judged >= args.sample:
                break
            if m["id"] in done and done[m["id"]].get("verdict") != "error" and not undecided(done[m["id"]]):
                continue
        scratch.sync_tests()
        r = judge(scratch, cfg, m, full)
        append(results_path, r)
        done.setdefault(m["id"], {}).update(r)
        if r.get("verdict") in ("killed", "survived"):
            judged += 1
        v = r.get("full_verdict") or r.get("verdict")
        print(f"[{judged}] {m['id']} line {m['line']}: {v} (build {r.get('build_s')} s, tests "
              f"{r.get('test_s', r.get('full_s'))} s) {r.get('detail', r.get('full_detail', ''))[:120]}",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
