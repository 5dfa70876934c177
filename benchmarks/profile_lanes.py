"""Where the lane kernel's time goes, instruction by instruction: sampled with ``perf``, mapped onto its machine code.

    python benchmarks/profile_lanes.py [--envs 1024] [--seconds 8] [--rate 10000] [--aero-model unsteady]

Runs the serial lane kernel of the aerodynamic model (``lanes.step_lanes_serial`` for the linear model, the
default; ``step_lanes_tables_serial``, ``step_lanes_unsteady_serial``; one thread, so every sample is the
kernel's own work) on a velocity-vector-roll batch under ``perf record -e cpu-clock`` (a software clock: virtual machines
rarely expose hardware counters), reads the kernel's machine code from numba's disk cache (an ELF
object, as ``tests/test_lanes.py`` does) and maps each sampled instruction pointer onto it through the
address at which the process loaded the kernel.  Prints the share of the samples per function of the
object, then within ``physics_step``: its loop with the most samples (the four RK stages over the lanes), the samples
on stack (spill) loads and stores and on other instructions with a stack operand, and per mnemonic.

A timer sample lands on the instruction the processor was about to retire when the interrupt came,
usually one waiting for an operand: shares say where the pipeline waits, not which instruction is slow.
Needs ``perf`` (Debian package linux-perf) and ``objdump`` (binutils).
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

_LABEL = re.compile(r"^([0-9a-f]+) <([^>]+)>:$")
_JUMP = re.compile(r"^j\w+\s+([0-9a-f]+)")
_MOVES = ("vmovupd", "vmovapd", "vmovups", "vmovaps", "vmovsd")


def child(n: int, seconds: float, aero_model: str) -> None:
    """Step the serial lane kernel of ``aero_model`` for ``seconds``; print the object's load address and its cache file."""
    import numpy as np

    from rig_env.envs import RigVectorEnv
    from rig_env.physics import lanes

    env = RigVectorEnv(n, aero_model=aero_model)
    env.physics.select_kernel("lanes", parallel=False)  # one thread: the samples are the kernel's alone
    env.reset(seed=0)
    a = np.random.default_rng(0).uniform(-1, 1, (n, 3))
    for _ in range(20):
        env.step(a)
    k, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        env.advance_physics()
        k += 1
    print(f"US_PER_STEP {(time.perf_counter() - t0) / k * 1e6:.1f}")
    kernel = lanes.KERNELS[{"linear": 0, "tables": 1, "unsteady": 2}[aero_model]][0]
    ((_, cres),) = kernel.overloads.items()
    print(f"ENTRY {cres.fndesc.llvm_func_name} {cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)}")
    name = kernel.py_func.__name__
    # the cache holds one object per compiled signature (other batches' table sizes are other literal arguments):
    # the one that defines this run's entry point
    entry = cres.fndesc.llvm_func_name.encode()
    cached = [f for f in sorted(Path(kernel._cache._cache_path).glob(f"lanes.{name}-*.nbc"), key=lambda f: -f.stat().st_mtime)
              if entry in f.read_bytes()]
    if not cached:
        sys.exit(f"no cached object of {name} defines {cres.fndesc.llvm_func_name[:80]}...")
    print(f"OBJECT {cached[0]}")


def disassemble(nbc: Path, work: Path) -> tuple[dict[int, str], dict[str, int]]:
    """Instructions {offset: text} of the cached object and {symbol: offset} of its functions."""
    data = nbc.read_bytes()
    obj = work / "kernel.o"
    obj.write_bytes(data[data.index(b"\x7fELF") :])
    asm = subprocess.run(["objdump", "-d", "--no-show-raw-insn", str(obj)], capture_output=True, text=True, check=True).stdout
    insns, symbols = {}, {}
    for line in asm.splitlines():
        m = _LABEL.match(line)
        if m:
            symbols[m.group(2)] = int(m.group(1), 16)
            continue
        m = re.match(r"^\s*([0-9a-f]+):\s+(\S.*)$", line)
        if m:
            insns[int(m.group(1), 16)] = m.group(2).strip()
    return insns, symbols


def report(counts: collections.Counter, insns: dict[int, str], symbols: dict[str, int], total: int) -> None:
    starts = sorted(symbols.items(), key=lambda kv: kv[1])
    end = max(insns) + 1
    spans = {name: (a, starts[i + 1][1] if i + 1 < len(starts) else end) for i, (name, a) in enumerate(starts)}
    in_object = sum(counts.values())
    print(f"samples: {total}, in the kernel's object {in_object} ({in_object / total:.1%}; the rest: Python, numpy, the OS)")

    def short(name: str) -> str:
        base = re.sub(r"B\d.*$", "", re.sub(r"^.*?\d+(physics_step|advance_block|stage_demands|step_lanes_serial)", r"\1", name))
        return base + (" (C-callable wrapper)" if name.startswith("cfunc.") else " (Python wrapper)" if "cpython" in name[:12] else "")

    for name, (a, b) in sorted(spans.items(), key=lambda kv: -sum(c for o, c in counts.items() if kv[1][0] <= o < kv[1][1])):
        c = sum(c for o, c in counts.items() if a <= o < b)
        if c:
            print(f"  {short(name)[:60]:60s} {c / in_object:6.1%}")
    step = next(((a, b) for name, (a, b) in spans.items() if "physics_step" in name), None)
    if step is None:
        print("no physics_step symbol in the object")
        return
    a, b = step
    body = sorted(o for o in insns if a <= o < b)
    ns = sum(counts[o] for o in body)
    print(f"\nphysics_step: {len(body)} instructions, {ns} samples")
    loops = []
    for o in body:
        m = _JUMP.match(insns[o])
        if m and int(m.group(1), 16) < o:
            t = int(m.group(1), 16)
            loops.append((sum(counts[x] for x in body if t <= x <= o), sum(1 for x in body if t <= x <= o), t, o))
    if loops:
        c, k, t, o = max(loops)
        print(f"  hottest loop {t:#x}-{o:#x} (the RK stages): {k} instructions, {c / ns:.1%} of the samples")
    stack = lambda o: "(%rsp)" in insns[o] or "(%rbp)" in insns[o]  # noqa: E731
    mnem = lambda o: insns[o].split()[0]  # noqa: E731
    spill_ld = [o for o in body if stack(o) and mnem(o) in _MOVES and re.search(r"\(%r[sb]p\),\s*%[xyz]mm", insns[o])]
    spill_st = [o for o in body if stack(o) and mnem(o) in _MOVES and re.search(r"%[xyz]mm\d+,\s*-?(0x[0-9a-f]+)?\(%r[sb]p\)", insns[o])]
    folded = [o for o in body if stack(o) and mnem(o) not in _MOVES]
    for label, group in (("stack loads (spill reloads)", spill_ld), ("stack stores (spills)", spill_st), ("arithmetic with a stack operand", folded)):
        print(f"  {label:34s} {len(group):5d} instructions, {sum(counts[o] for o in group) / ns:6.1%} of the samples")
    by = collections.Counter()
    static = collections.Counter(mnem(o) for o in body)
    for o in body:
        by[mnem(o)] += counts[o]
    print("  per mnemonic (samples, instructions):")
    for k, c in by.most_common(12):
        print(f"    {k:14s} {c / ns:6.1%} {static[k]:5d}")
    for k in ("vdivpd", "vsqrtpd"):
        print(f"    {k:14s} {by[k] / ns:6.1%} {static[k]:5d}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=1024)
    ap.add_argument("--seconds", type=float, default=8.0)
    ap.add_argument("--rate", type=int, default=10000, help="samples per second (perf -F)")
    ap.add_argument("--aero-model", choices=("linear", "tables", "unsteady"), default="linear")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.envs, args.seconds, args.aero_model)
        return
    missing = [t for t in ("perf", "objdump") if shutil.which(t) is None]
    if missing:
        sys.exit(f"needs {' and '.join(missing)} (Debian packages linux-perf, binutils)")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        data = work / "perf.data"
        cmd = ["perf", "record", "-q", "-e", "cpu-clock", "-F", str(args.rate), "-o", str(data), "--",
               sys.executable, __file__, "--child", "--envs", str(args.envs), "--seconds", str(args.seconds),
               "--aero-model", args.aero_model]
        run = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "NUMBA_NUM_THREADS": "1"})
        if run.returncode != 0:
            sys.exit(f"perf record failed ({run.returncode}): {run.stderr.strip()[-500:]}")
        out = dict(line.split(" ", 1) for line in run.stdout.splitlines() if line.split(" ", 1)[0] in ("US_PER_STEP", "ENTRY", "OBJECT"))
        entry_name, entry_addr = out["ENTRY"].split()
        insns, symbols = disassemble(Path(out["OBJECT"]), work)
        base = int(entry_addr) - symbols[entry_name]  # where the object's code was loaded
        ips = subprocess.run(["perf", "script", "-i", str(data), "-F", "ip"], capture_output=True, text=True, check=True).stdout.split()
        counts = collections.Counter(int(ip, 16) - base for ip in ips)
        counts = collections.Counter({o: c for o, c in counts.items() if o in insns})
        print(f"# {out['ENTRY'].split()[0][:60]} ({args.aero_model}), {args.envs} environments, one thread: {out['US_PER_STEP']} us per control step under perf")
        report(counts, insns, symbols, len(ips))


if __name__ == "__main__":
    main()
