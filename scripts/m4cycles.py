"""Two cycle models of the Cortex-M4 (with its single-precision FPU) for executed instruction traces.

Each executed instruction costs what Arm's Cortex-M4 Technical Reference Manual (r0p1, section
3.3.1, "Cortex-M4 instructions", and chapter 7, "FPU instruction set") gives for it, with these
readings, each a simplification that `docs/performance.md` states. The two models differ in one
rule only, the manual's footnote that neighbouring single loads and stores pipeline:

- `PIPELINED`: a single load or store that follows a single load (below) costs 1 instead of 2;
- `UNPIPELINED`: every single load or store costs 2, wherever it stands: the manual's table
  without that footnote, the bound for code whose loads the core does not overlap.

The rest, common to both:

- data processing, moves, compares, shifts, bit-field and extend operations, `MUL`, `MLA`,
  the long multiplies, `NOP`: 1; `MLS`: 2; `SDIV`/`UDIV`: 12 (the manual's worst case of 2-12);
- a single load or store (`LDR`, `STR` and their byte, halfword, signed and exclusive forms,
  `VLDR`, `VSTR`): 2; under `PIPELINED`, 1 when it pipelines behind the single load just before
  it: neighbouring loads and stores overlap their address and data phases, unless the
  instruction before was a store, used write-back, or loaded the register this one takes its
  address from;
- `LDRD`/`STRD`: 3; `LDM`/`STM`/`PUSH`/`POP` of N registers: 1 + N; `VLDM`/`VSTM`/`VPUSH`/
  `VPOP` of N single-precision registers (a double counts two): 1 + N;
- a branch taken (`B`, `BL`, `BX`, `BLX`, a conditional branch, `CBZ`/`CBNZ`): 1 + P with the
  pipeline refill P = 2 (the manual gives 1 to 3, by the target's alignment and width); not
  taken: 1; a write to the PC by a load or data-processing instruction: its cost + P;
- `IT`: 1 (the M4 can fold it into the 16-bit instruction before; not modelled: an upper bound);
  an instruction inside an IT block whose condition fails is charged as if it executed
  (the trace does not say which did; an upper bound);
- FPU: `VADD`, `VSUB`, `VMUL`, `VNMUL`, `VABS`, `VNEG`, `VCMP(E)`, `VCVT`, `VMOV` (immediate,
  register, one core register), `VMRS`, `VMSR`: 1; `VMOV` of two core registers: 2;
  `VMLA`, `VMLS`, `VNMLA`, `VNMLS`, `VFMA`, `VFMS`, `VFNMA`, `VFNMS`: 3; `VDIV`, `VSQRT`: 14.

Not modelled: flash wait states and the ART accelerator (5 wait states at 168 MHz, hidden by the
prefetch buffer and the 1 KiB instruction cache on straight-line and cached code; the model is
zero-wait-state memory), bus contention with DMA, the literal-pool load's possible extra cycle,
and interrupt entry and exit (12 cycles each with zero wait states, plus 17 for a lazy FP
context save when the handler uses the FPU). The models are what `scripts/fw-cycles` applies to
QEMU's execution trace; `scripts/test_m4cycles.py` checks it on hand-worked sequences.
"""
import re

# Pipeline refill of a taken branch, in cycles (the manual: 1 to 3).
REFILL = 2

# The two models (module docs), by the names the bench's output uses.
PIPELINED = "pipelined"
UNPIPELINED = "unpipelined"
MODELS = (PIPELINED, UNPIPELINED)

_COND = r"(?:eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le|al)"

_FP_MAC = {"vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms"}
_FP_LONG = {"vdiv", "vsqrt"}
_LOADS = {"ldr", "ldrb", "ldrh", "ldrsb", "ldrsh", "ldrex", "ldrexb", "ldrexh", "ldrt",
          "ldrbt", "ldrht", "ldrsbt", "ldrsht", "vldr"}
_STORES = {"str", "strb", "strh", "strex", "strexb", "strexh", "strt", "strbt", "strht", "vstr"}
_MULTI = {"ldm", "ldmia", "ldmfd", "ldmdb", "stm", "stmia", "stmea", "stmdb", "stmfd", "push", "pop"}
_VMULTI = {"vldm", "vldmia", "vldmdb", "vstm", "vstmia", "vstmdb", "vpush", "vpop"}
_BRANCH = {"b", "bl", "bx", "blx", "cbz", "cbnz", "tbb", "tbh"}


_KNOWN = _FP_MAC | _FP_LONG | _LOADS | _STORES | _MULTI | _VMULTI | _BRANCH | {
    "ldrd", "strd", "vmov", "mls", "sdiv", "udiv"}


def base_mnemonic(mnemonic):
    """The operation of a disassembled mnemonic, as far as its cost depends on it: no width
    (`.w`) or data type (`.f32`), no condition (`beq` → `b`), no flag-setting `s`."""
    m = mnemonic.lower().split(".")[0]
    if re.fullmatch(r"it[te]{0,3}", m):
        return "it"
    candidates = [m]
    if len(m) > 2 and re.fullmatch(_COND, m[-2:]):
        candidates.append(m[:-2])
    for c in candidates:
        for x in (c, c[:-1] if c.endswith("s") else None):
            if x in _KNOWN:
                return x
    return m


def _registers(text):
    """Register names in an operand string, lower case (`sp`, `lr`, `pc` kept)."""
    return re.findall(r"\b(r\d+|sp|lr|pc|ip|fp|sb|sl|[sd]\d+)\b", text.lower())


def _reglist_count(text):
    """Number of 32-bit registers in a `{...}` list: ranges expanded, a D register counts two."""
    m = re.search(r"\{([^}]*)\}", text)
    if not m:
        return 1
    n = 0
    for part in m.group(1).split(","):
        part = part.strip().lower()
        width = 2 if part.startswith("d") else 1
        r = re.fullmatch(r"([rsd])(\d+)\s*-\s*[rsd](\d+)", part)
        n += width * (int(r.group(3)) - int(r.group(2)) + 1) if r else width
    return n


class Access:
    """What a single load or store leaves for the next instruction's pipelining."""

    def __init__(self, load, dest, writeback):
        self.load, self.dest, self.writeback = load, dest, writeback


def _address_registers(operands):
    m = re.search(r"\[([^\]]*)\]", operands)
    return _registers(m.group(1)) if m else []


def _writeback(operands):
    return operands.rstrip().endswith("!") or bool(re.search(r"\]\s*,", operands))


def cost(mnemonic, operands, taken, previous, model=PIPELINED):
    """Cycles of one executed instruction under `model`, and the access it leaves for the next.

    `taken`: for a branch, whether the trace went elsewhere than the next instruction.
    `previous`: the `Access` the instruction before left, or None.
    """
    if model not in MODELS:
        raise ValueError(f"unknown cycle model {model!r}")
    op = base_mnemonic(mnemonic)
    ops = operands.lower()
    regs = _registers(ops)
    writes_pc = bool(regs) and regs[0] == "pc"
    if op in _LOADS or op in _STORES:
        load = op in _LOADS
        wb = _writeback(ops)
        addr = _address_registers(ops)
        pipelined = (
            model == PIPELINED
            and previous is not None
            and previous.load
            and not previous.writeback
            and not wb
            and "pc" not in addr
            and (previous.dest is None or previous.dest not in addr)
        )
        c = 1 if pipelined else 2
        if load and writes_pc:
            c += REFILL
        return c, Access(load, regs[0] if regs else None, wb)
    if op in ("ldrd", "strd"):
        return 3, None
    if op in _MULTI:
        n = _reglist_count(ops)
        pc = op in ("pop", "ldm", "ldmia", "ldmfd", "ldmdb") and "pc" in _registers(ops.split("{", 1)[-1])
        return 1 + n + (REFILL if pc else 0), None
    if op in _VMULTI:
        return 1 + _reglist_count(ops), None
    if op in _BRANCH:
        return (1 + REFILL if taken else 1), None
    if op == "it":
        return 1, None
    if op in _FP_MAC:
        return 3, None
    if op in _FP_LONG:
        return 14, None
    if op == "vmov":
        core = sum(1 for r in regs if r.startswith("r") or r in ("sp", "lr", "ip", "fp", "sb", "sl"))
        return (2 if core >= 2 else 1), None
    if op == "mls":
        return 2, None
    if op in ("sdiv", "udiv"):
        return 12, None
    return 1 + (REFILL if writes_pc else 0), None


def cycles(trace, model=PIPELINED):
    """Total cycles of a trace, a list of `(mnemonic, operands, taken)`, under `model`."""
    total, previous = 0, None
    for mnemonic, operands, taken in trace:
        c, previous = cost(mnemonic, operands, taken, previous, model)
        total += c
    return total
