"""The bench firmware's execution trace under QEMU, shared by scripts/fw-cycles and scripts/fw-profile.

The bench (firmware/src/bin/bench.rs) reads TIM5's counter with `LDREX`, an instruction no
measured function executes, at both edges of every timed region, inside never-inlined wrappers
`bench::call_<name>`. QEMU logs every instruction those wrappers and their callees execute
(`-d exec,nochain` with one instruction per translation block); a timed region is what runs
strictly between a wrapper's two `LDREX`.
"""
import collections
import os
import re
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BENCH_ELF = os.path.join(ROOT, "target/thumbv7em-none-eabihf/release/bench")


def die(msg):
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(2)


def tool(name, hint):
    path = shutil.which(name)
    if path is None:
        die(f"{name} not found: {hint}")
    return path


def llvm_tool(name):
    sysroot = subprocess.run(["rustc", "--print", "sysroot"], capture_output=True, text=True).stdout.strip()
    for dirpath, _, files in os.walk(os.path.join(sysroot, "lib/rustlib")):
        if name in files:
            return os.path.join(dirpath, name)
    die(f"{name} not found: run 'rustup component add llvm-tools'")


def disassemble(elf):
    """Functions as a sorted list of (start, end, name) and instructions as
    {address: (mnemonic, operands)}."""
    out = subprocess.run([llvm_tool("llvm-objdump"), "-d", "--no-show-raw-insn", "-C", elf],
                         capture_output=True, text=True, check=True).stdout
    starts, insns = [], {}
    for line in out.splitlines():
        m = re.match(r"^([0-9a-f]{8}) <(.*)>:$", line)
        if m:
            starts.append((int(m.group(1), 16), m.group(2)))
            continue
        m = re.match(r"^ +([0-9a-f]+):\s+(\S+)\s*([^@;]*)", line)
        if m:
            insns[int(m.group(1), 16)] = (m.group(2), m.group(3).strip())
    starts.sort()
    last = max(insns) + 4
    funcs = [(a, starts[i + 1][0] if i + 1 < len(starts) else last, n) for i, (a, n) in enumerate(starts)]
    return funcs, insns


def wrappers(funcs):
    """{`call_<name>`: (start, end)} of the bench's measured wrappers."""
    out = {}
    for a, e, n in funcs:
        m = re.search(r"bench::(?:\w+::)?(call_\w+?)(?:::h[0-9a-f]{16})?$", n)
        if m:
            out[m.group(1)] = (a, e)
    return out


def callees(funcs, insns, roots):
    """(start, end) of the functions in `roots` and of everything they call, transitively."""
    by_start = {a: (a, e) for a, e, _ in funcs}
    seen, todo = set(), list(roots)
    while todo:
        f = todo.pop()
        if f in seen or f not in by_start:
            continue
        seen.add(f)
        for a in range(f, by_start[f][1], 2):
            mnemonic, operands = insns.get(a, ("", ""))
            m = re.match(r"0x([0-9a-f]+)", operands)
            if mnemonic in ("bl", "b", "b.w") and m:
                todo.append(int(m.group(1), 16))
    return sorted(by_start[f] for f in seen)


def qemu_command(elf, ranges, log):
    """QEMU on the netduinoplus2 with the trace of `ranges` written to `log`."""
    qemu = tool("qemu-system-arm", "apt-get install qemu-system-arm")
    # One instruction per translation block, so that the trace lists every instruction:
    # `-singlestep` up to QEMU 8.0, `one-insn-per-tb` from 8.1 on.
    helptext = subprocess.run([qemu, "-h"], capture_output=True, text=True).stdout
    one_insn = ["-singlestep"] if "-singlestep" in helptext else ["-accel", "tcg,one-insn-per-tb=on"]
    dfilter = ",".join(f"0x{a:x}..0x{b - 1:x}" for a, b in ranges)
    return [qemu, "-machine", "netduinoplus2", "-nographic", "-monitor", "none", "-serial", "none",
            "-semihosting-config", "enable=on,target=native", "-icount", "shift=0,sleep=off",
            *one_insn, "-d", "exec,nochain", "-dfilter", dfilter, "-D", log, "-kernel", elf]


def executed(log):
    """Addresses of the executed instructions, in order. A logged block that did not run to its
    end is dropped: under `-icount` QEMU rewinds an instruction that touches a device and runs
    it again ("cpu_io_recompile: rewound"), and it logs a block before it checks for a pending
    interrupt or timer deadline, which may stop it ("Stopped execution of TB chain before")."""
    pending = None
    with open(log) as f:
        for n, line in enumerate(f, 1):
            if line.startswith(("cpu_io_recompile: rewound", "Stopped execution of TB chain")):
                pending = None
            elif line.startswith("Trace"):
                if pending is not None:
                    yield pending
                fields = line.split("/")
                if len(fields) < 2:
                    die(f"{log}:{n}: a trace line without its block's address: the log is cut "
                        "(the disk full?)")
                pending = int(fields[1], 16)
    if pending is not None:
        yield pending


def marks(insns, calls):
    """{address of an LDREX: wrapper name} for the wrappers `calls` ({name: (start, end)});
    each must read the counter exactly twice."""
    out = {}
    for w, (a, e) in calls.items():
        found = [x for x in range(a, e, 2) if insns.get(x, ("",))[0] == "ldrex"]
        if len(found) != 2:
            die(f"{w} does not read the counter exactly twice with LDREX")
        out.update({x: w for x in found})
    return out


def regions(log, mark):
    """Timed regions of the trace, as {wrapper: [[address, ...], ...]} in call order; each
    list ends with the closing `LDREX`, which is not part of the region."""
    out = collections.defaultdict(list)
    current, trace = None, []
    for a in executed(log):
        if current is not None:
            trace.append(a)
        if a in mark:
            if current is None:
                current, trace = mark[a], []
            else:
                out[current].append(trace)
                current = None
    return out


def successors(insns):
    """{address: address of the next instruction in the image}."""
    addrs = sorted(insns)
    return dict(zip(addrs, addrs[1:]))


def instructions(insns, succ, trace):
    """A region as the cycle model takes it: (mnemonic, operands, taken) per instruction, where
    a branch is taken when the next executed address is not the next instruction's."""
    return [(*insns.get(a, ("?", "")), nxt != succ.get(a)) for a, nxt in zip(trace, trace[1:])]
