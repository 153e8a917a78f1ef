"""The Cortex-M4 cycle models (`m4cycles.py`) on hand-worked sequences.

Run: python3 -m unittest discover -s scripts -p 'test_*.py'
"""
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import m4cycles  # noqa: E402


def seq(text, taken=()):
    """Lines `mnemonic operands` → a trace; the line numbers in `taken` are taken branches."""
    out = []
    for i, line in enumerate(l.strip() for l in text.strip().splitlines()):
        mnemonic, _, operands = line.partition(" ")
        out.append((mnemonic, operands.strip(), i in taken))
    return out


class Mnemonics(unittest.TestCase):
    def test_suffixes(self):
        for raw, base in [("vmla.f32", "vmla"), ("ldr.w", "ldr"), ("beq.n", "b"), ("bne", "b"),
                          ("adds", "adds"), ("itte", "it"), ("it", "it"), ("vpop", "vpop"),
                          ("ldreq", "ldr"), ("vdiv.f32", "vdiv"), ("teq", "teq"), ("cbz", "cbz"),
                          ("strd", "strd"), ("ldrex", "ldrex"), ("mls", "mls")]:
            self.assertEqual(m4cycles.base_mnemonic(raw), base, raw)


class Sequences(unittest.TestCase):
    def test_straight_line_fp_is_one_cycle_each(self):
        # 4 adds, 3 multiplies, a negate, a compare and a flag transfer: 10 instructions.
        t = seq("""
            vadd.f32 s0, s1, s2
            vadd.f32 s3, s0, s2
            vsub.f32 s4, s3, s1
            vadd.f32 s5, s4, s4
            vmul.f32 s6, s5, s5
            vmul.f32 s7, s6, s1
            vnmul.f32 s8, s7, s1
            vneg.f32 s9, s8
            vcmp.f32 s9, #0
            vmrs APSR_nzcv, fpscr
        """)
        self.assertEqual(m4cycles.cycles(t), 10)

    def test_multiply_accumulate_costs_three(self):
        # VMLA: 3 cycles, where VMUL + VADD take 2 (the reason for target-cpu=cortex-m4).
        self.assertEqual(m4cycles.cycles(seq("vmla.f32 s0, s1, s2")), 3)
        self.assertEqual(m4cycles.cycles(seq("vmul.f32 s3, s1, s2\nvadd.f32 s0, s0, s3")), 2)
        self.assertEqual(m4cycles.cycles(seq("vfma.f32 s0, s1, s2\nvfms.f32 s0, s1, s2")), 6)

    def test_division_and_square_root(self):
        self.assertEqual(m4cycles.cycles(seq("vdiv.f32 s0, s1, s2\nvsqrt.f32 s3, s0")), 28)

    def test_loads_pipeline_unless_dependent(self):
        # Three independent loads: 2 + 1 + 1.
        t = seq("""
            ldr r0, [r4]
            ldr r1, [r4, #4]
            vldr s0, [r4, #8]
        """)
        self.assertEqual(m4cycles.cycles(t), 4)
        # A load whose address is the previous load's result: 2 + 2.
        self.assertEqual(m4cycles.cycles(seq("ldr r0, [r4]\nldr r1, [r0, #4]")), 4)
        # Write-back is not pipelined: 2 + 2, and the next one neither: + 2.
        self.assertEqual(m4cycles.cycles(seq("ldr r0, [r4], #4\nldr r1, [r4]\nldr r2, [r5]")), 5)
        # A load after a store does not pipeline; a store after a load does: 2 + 2 + 1.
        self.assertEqual(m4cycles.cycles(seq("str r0, [r4]\nldr r1, [r5]\nstr r1, [r6]")), 5)

    def test_multiple_transfers(self):
        # push {r4-r7, lr}: 1 + 5; vpush {d8-d9}: 1 + 4; pop {r4-r7, pc}: 1 + 5 + P.
        t = seq("""
            push {r4, r5, r6, r7, lr}
            vpush {d8, d9}
            vpop {d8, d9}
            pop {r4, r5, r6, r7, pc}
        """)
        self.assertEqual(m4cycles.cycles(t), 6 + 5 + 5 + 6 + m4cycles.REFILL)
        self.assertEqual(m4cycles.cycles(seq("push {r4-r7, lr}")), 6)
        self.assertEqual(m4cycles.cycles(seq("ldrd r0, r1, [r2]")), 3)

    def test_branches(self):
        t = seq("""
            cmp r0, #0
            beq.n 0x100
            bl 0x200
            bx lr
        """, taken={2, 3})
        # cmp 1, beq not taken 1, bl 1 + P, bx 1 + P.
        self.assertEqual(m4cycles.cycles(t), 4 + 2 * m4cycles.REFILL)
        self.assertEqual(m4cycles.cycles(seq("bne 0x100", taken={0})), 1 + m4cycles.REFILL)

    def test_integer(self):
        t = seq("""
            movs r0, #1
            movw r1, #3108
            movt r1, #16384
            mul r2, r0, r1
            mls r3, r0, r1, r2
            udiv r4, r3, r1
            it eq
            moveq r5, #0
        """)
        self.assertEqual(m4cycles.cycles(t), 1 + 1 + 1 + 1 + 2 + 12 + 1 + 1)

    def test_core_register_transfers(self):
        self.assertEqual(m4cycles.cycles(seq("vmov r0, s0")), 1)
        self.assertEqual(m4cycles.cycles(seq("vmov r0, r1, d0")), 2)
        self.assertEqual(m4cycles.cycles(seq("vmov.f32 s0, #1.0")), 1)


class Unpipelined(unittest.TestCase):
    """The second model: every single load or store costs 2; everything else as the first."""

    U = m4cycles.UNPIPELINED

    def test_loads_never_pipeline(self):
        # The three independent loads that cost 2 + 1 + 1 pipelined: 2 + 2 + 2.
        t = seq("""
            ldr r0, [r4]
            ldr r1, [r4, #4]
            vldr s0, [r4, #8]
        """)
        self.assertEqual(m4cycles.cycles(t, self.U), 6)
        # A store after a load: 2 + 2 (pipelined: 2 + 1).
        self.assertEqual(m4cycles.cycles(seq("vldr s0, [r0]\nvstr s0, [r1]"), self.U), 4)
        self.assertEqual(m4cycles.cycles(seq("vldr s0, [r0]\nvstr s0, [r1]")), 3)

    def test_only_single_accesses_differ(self):
        # Multiple transfers, doubleword accesses, branches and FP arithmetic cost the same in
        # both models: a sequence without two neighbouring single accesses costs the same.
        t = seq("""
            push {r4, r5, r6, r7, lr}
            vldm r0, {s0-s3}
            ldrd r2, r3, [r1]
            vmla.f32 s0, s1, s2
            ldr r0, [r1]
            vadd.f32 s4, s0, s1
            str r0, [r2]
            pop {r4, r5, r6, r7, pc}
        """, taken={7})
        want = 6 + 5 + 3 + 3 + 2 + 1 + 2 + 6 + m4cycles.REFILL
        self.assertEqual(m4cycles.cycles(t), want)
        self.assertEqual(m4cycles.cycles(t, self.U), want)

    def test_never_cheaper_than_pipelined(self):
        # The same trace costs at least as much without pipelining, by one cycle per access
        # that pipelined: here the second and third loads and the store after a load.
        t = seq("""
            ldr r0, [r4]
            vldr s0, [r4, #4]
            vldr s1, [r4, #8]
            vmul.f32 s2, s0, s1
            vldr s3, [r5]
            vstr s2, [r5, #4]
        """)
        self.assertEqual(m4cycles.cycles(t), 2 + 1 + 1 + 1 + 2 + 1)
        self.assertEqual(m4cycles.cycles(t, self.U), 2 + 2 + 2 + 1 + 2 + 2)

    def test_unknown_model_is_refused(self):
        with self.assertRaises(ValueError):
            m4cycles.cycles(seq("nop"), "fast")


if __name__ == "__main__":
    unittest.main()
