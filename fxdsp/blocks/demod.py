"""Synchronous demodulator: NCO (phase accumulator + cos/sin LUT), two mixers, two low-pass filters
(the ``iir`` block), and a CORDIC for amplitude and phase (drive loop; paper 003's sweep).

* NCO: ``phase[n] = (n * ftw + phase0) mod 2**phase_bits`` with ``ftw = f_hz / fs_hz * 2**phase_bits``
  quantised half_up (an open-loop frequency error of up to half a tuning-word LSB: its phase drift is
  why the default accumulator is 48 bits). Phase trim (``phase_trim_rad``, optional, 0 = none): a
  constant added to the accumulator word before the table is read, ``ref[n] = (phase[n] + trim) mod
  2**phase_bits`` with ``trim = phase_trim_rad / (2 pi) * 2**phase_bits`` quantised half_up, wrapped
  (LSB 2 pi / 2**phase_bits: 2.2e-14 rad at 48 bits). It rotates the demodulator's reference, not
  the drive (``carrier`` and the accumulator state are unchanged): a sense signal ``cos(w t + phi)``
  (a pick-off phase error phi, quadrature leaking into I by c = -tan phi) demodulates to
  ``I = cos(phi - trim)``, so ``trim = phi = -atan(c)`` (what ``fxdsp diagnose`` proposes) removes it.
  One quarter-wave sine table, ``qsin[k] = sin((k + 1/2) (pi/2) / 2**(lut_bits-2))`` (bin centres,
  ``lut_format``, half_up, saturated), serves cos and -sin over the whole turn by quadrant symmetry:
  the top ``lut_bits`` phase bits are the bin (quadrant, index), the two reads are ``qsin[k]`` and ``qsin[~k]``. First-order (Taylor) interpolation removes
  the phase-truncation error: the next ``interp_bits`` phase bits give the offset from the bin centre,
  ``delta = (2 r + 1 - 2**interp_bits) / 2**(interp_bits+1)`` bins (the centre of each sub-bin, so the
  offset itself has no truncation bias), ``d = delta_code * two_pi`` (2 pi on TWO_PI_FORMAT), and
  ``cos = cb + R(mb * d)``, ``-sin = mb + R(-cb * d)`` with ``R`` = shift right by ``corr_shift``
  rounded by ``rounding``: d cos/d phase = -sin and d(-sin)/d phase = -cos, both read anyway. The
  result is one integer bit wider than the table (``nco_format``): it cannot overflow (checked when
  built), so the NCO has no fit point. ``interp_bits = 0`` is the plain truncating table.
* Mixers: ``i = 2 x cos``, ``q = -2 x sin`` exact products, the factor 2 taken by reading the
  product one fraction bit coarser (so I and Q are the in-phase and quadrature *amplitudes*),
  then rounded by ``rounding`` and fitted by ``overflow`` into ``data_format``.
* Low-pass: one ``iir`` per channel with the ``[demod.lpf]`` design, data_format = demod's.
* CORDIC (vectoring, ``cordic_iterations`` steps): pre-rotation by +-90 deg into the right half
  plane, then x, y updated with arithmetic right shifts (``floor``: the shifts truncate) in
  data_format widened by 2 guard bits, the angle accumulated from an arctan table in
  ``angle_format`` (radians). Amplitude = x * (1/K) with 1/K quantised in s18.17, rounded by
  ``rounding`` into data_format; phase = the angle accumulator.

Float reference: exact cos/sin of the exact phase (drive phase + the unquantised trim), float
mixers, scipy sosfilt with the float design, hypot and arctan2.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numba import njit

from fxdsp.config import Section
from fxdsp.fixed import Format, OverflowLog, Rules, product_format, quantize, resize
from fxdsp.fixed.kernels import convert, shift_right_round
from fxdsp.blocks.base import Block, corner_codes
from fxdsp.blocks.datapath import Datapath, limbs, OvfField, Rom, RtlPorts, const, info, nested
from fxdsp.blocks.iir import Iir, IirDatapath
from fxdsp.errors import InputError


@njit(cache=True)
def _nco_wave(phase, addr_shift, lut_bits, interp_bits, qsin, two_pi, corr_shift, rounding):
    """(cos, -sin) of one phase word on nco_format: quarter-wave bin-centre values and the
    first-order correction from the sub-bin offset (see the module docstring)."""
    a = phase >> addr_shift
    qbits = lut_bits - 2
    qmask = (np.int64(1) << qbits) - 1
    quad = (a >> qbits) & 3
    k = a & qmask
    s_k = qsin[k]
    s_r = qsin[qmask - k]
    if quad == 0:
        cb, mb = s_r, -s_k
    elif quad == 1:
        cb, mb = -s_k, -s_r
    elif quad == 2:
        cb, mb = -s_r, s_k
    else:
        cb, mb = s_k, s_r
    r = (phase >> (addr_shift - interp_bits)) & ((np.int64(1) << interp_bits) - 1)
    d = (2 * r + 1 - (np.int64(1) << interp_bits)) * two_pi
    return (cb + shift_right_round(mb * d, corr_shift, rounding),
            mb + shift_right_round(-cb * d, corr_shift, rounding))


@njit(cache=True)
def _nco_waves(phases, addr_shift, lut_bits, interp_bits, qsin, two_pi, corr_shift, rounding):
    n = phases.shape[0]
    c = np.empty(n, dtype=np.int64)
    m = np.empty(n, dtype=np.int64)
    for k in range(n):
        c[k], m[k] = _nco_wave(phases[k], addr_shift, lut_bits, interp_bits, qsin, two_pi, corr_shift, rounding)
    return c, m


@njit(cache=True)
def _mix_kernel(x, phase0, ftw, trim, phase_mask, addr_shift, lut_bits, interp_bits, qsin, two_pi, corr_shift,
                shift, rounding, lo, hi, overflow, counts, ref):
    """NCO + both mixers. phase = (phase0 + n ftw) mod 2**phase_bits accumulated sample by sample
    (masking after each add keeps it within 49 bits), or the external reference ``ref[n]`` when
    ``ref`` has a word per sample; the table read at (phase + trim) mod 2**phase_bits (both
    < 2**48: the sum fits 49 bits); counts += (I fits, Q fits)."""
    n = x.shape[0]
    i_out = np.empty(n, dtype=np.int64)
    q_out = np.empty(n, dtype=np.int64)
    external = ref.shape[0] == n
    phase = phase0
    for k in range(n):
        if external:
            phase = ref[k]
        c, m = _nco_wave((phase + trim) & phase_mask, addr_shift, lut_bits, interp_bits, qsin, two_pi, corr_shift,
                         rounding)
        v, o = convert(x[k] * c, shift, rounding, lo, hi, overflow)
        i_out[k] = v
        counts[0] += o
        v, o = convert(x[k] * m, shift, rounding, lo, hi, overflow)
        q_out[k] = v
        counts[1] += o
        phase = (phase + ftw) & phase_mask
    return i_out, q_out, phase


@njit(cache=True)
def cordic_one(x, y, atans, half_pi, iterations):
    """CORDIC vectoring of one (x, y): pre-rotate into the right half plane, then shift-and-add
    (arithmetic right shifts: floor). Returns (K * magnitude, angle) as stored integers."""
    z = np.int64(0)
    if x < 0:
        if y >= 0:
            x, y, z = y, -x, half_pi
        else:
            x, y, z = -y, x, -half_pi
    for j in range(iterations):
        dx = y >> j
        dy = x >> j
        if y >= 0:
            x, y, z = x + dx, y - dy, z + atans[j]
        else:
            x, y, z = x - dx, y + dy, z - atans[j]
    return x, z


@njit(cache=True)
def _cordic_kernel(i_in, q_in, atans, half_pi, iterations):
    """:func:`cordic_one` over arrays."""
    n = i_in.shape[0]
    xs = np.empty(n, dtype=np.int64)
    zs = np.empty(n, dtype=np.int64)
    for k in range(n):
        xs[k], zs[k] = cordic_one(i_in[k], q_in[k], atans, half_pi, iterations)
    return xs, zs


INV_K_FORMAT = Format(True, 18, 17)


TWO_PI_FORMAT = Format(True, 16, 12)   # 2 pi of the interpolation step: relative error 3e-6, i.e. < 0.005
# table LSB on the largest correction (pi / 2**lut_bits); a wider constant only widens the products


class Nco:
    """Phase accumulator, quarter-wave sine table and first-order interpolation (cos, -sin), read
    at the accumulator plus a constant phase trim (the reference's rotation, 0 = none)."""

    def __init__(self, fs_hz: float, f_hz: float, phase_bits: int, lut_bits: int, lut_format: Format,
                 phase_offset_turns: float = 0.0, interp_bits: int = 0, rules: Rules = Rules("half_up", "saturate"),
                 phase_trim_rad: float = 0.0, name: str = "demod"):
        if not 0 < f_hz < fs_hz / 2:
            raise InputError(f"{name}.f_hz: must be within (0, fs/2 = {fs_hz / 2}), got {f_hz}")
        if not 4 <= lut_bits <= phase_bits <= 48:
            raise InputError(f"{name}.lut_bits/phase_bits: need 4 <= lut_bits <= phase_bits <= 48, "
                             f"got {lut_bits}, {phase_bits}")
        if not 0 <= interp_bits <= phase_bits - lut_bits:
            raise InputError(f"{name}.interp_bits: must be within 0..phase_bits - lut_bits = "
                             f"{phase_bits - lut_bits}, got {interp_bits}")
        # the correction product qsin x delta_code x two_pi must fit 63 bits
        if lut_format.wl + interp_bits + TWO_PI_FORMAT.wl - 1 > 63:
            raise InputError(f"{name}.interp_bits: {interp_bits} with lut_format {lut_format} makes the "
                             f"interpolation product {lut_format.wl + interp_bits + TWO_PI_FORMAT.wl - 1} bits; "
                             f"more than 63")
        self.fs_hz, self.f_hz = fs_hz, f_hz
        self.phase_bits, self.lut_bits, self.lut_format = phase_bits, lut_bits, lut_format
        self.interp_bits, self.rules = interp_bits, rules
        self.phase_format = Format(False, phase_bits, phase_bits)  # turns
        self.ftw = int(quantize([f_hz / fs_hz], self.phase_format, Rules("half_up", "saturate"))[0])
        self.phase0 = int(quantize([phase_offset_turns % 1.0], self.phase_format, Rules("half_up", "wrap"))[0])
        self.phase_offset_turns = phase_offset_turns
        if not abs(phase_trim_rad) <= np.pi:
            raise InputError(f"{name}.phase_trim_rad: must be within [-pi, pi], got {phase_trim_rad}")
        # the trim word: turns * 2**phase_bits, nearest (half_up), modulo one turn
        self.phase_trim_rad = phase_trim_rad
        turns = (phase_trim_rad / (2 * np.pi)) % 1.0
        self.trim = int(quantize([turns], self.phase_format, Rules("half_up", "wrap"))[0])
        quarter = 2 ** (lut_bits - 2)
        self.qsin = self.lut_quantize(np.sin(0.5 * np.pi * (np.arange(quarter) + 0.5) / quarter))
        self.two_pi = int(quantize([2 * np.pi], TWO_PI_FORMAT, Rules("half_up", "saturate"))[0])
        self.corr_shift = interp_bits + 1 + TWO_PI_FORMAT.fl + lut_bits
        self.nco_format = Format(True, lut_format.wl + 1, lut_format.fl)
        self.phase_mask = (1 << phase_bits) - 1
        self.addr_shift = phase_bits - lut_bits
        # proof that the interpolated value fits nco_format: the largest table value plus the
        # largest correction (|delta| < 1/2 bin, rounded up by one LSB)
        corr_max = ((lut_format.max_int * ((1 << interp_bits) - 1) * self.two_pi) >> self.corr_shift) + 1
        assert lut_format.max_int + corr_max <= self.nco_format.max_int, "NCO output format too narrow"
        self.reset()

    def lut_quantize(self, values) -> np.ndarray:
        """cos / -sin values as the LUT stores them: nearest (half_up), saturated (cos 0 = 1 cannot be
        held by an s.15 word)."""
        return quantize(values, self.lut_format, Rules("half_up", "saturate"))

    def reset(self) -> None:
        self.phase = self.phase0  # the accumulator

    def drive_phase(self, count: int, start: int = 0) -> np.ndarray:
        """The exact drive phase (radians) of samples start.. (what ``carrier`` follows; no trim)."""
        n = np.arange(start, start + count, dtype=float)
        return 2 * np.pi * (self.phase_offset_turns + n * self.f_hz / self.fs_hz)

    def reference_phase(self, count: int, start: int = 0) -> np.ndarray:
        """The exact phase (radians) the NCO's cos / -sin represent: the drive phase plus the
        unquantised trim."""
        return self.drive_phase(count, start) + self.phase_trim_rad

    def accumulator(self, count: int) -> np.ndarray:
        """The accumulator's words for the first ``count`` samples after reset (no trim): what a
        demodulator with an external reference is fed to run as its own NCO would."""
        n = np.arange(count, dtype=np.uint64)
        return ((np.uint64(self.phase0) + n * np.uint64(self.ftw)) & np.uint64(self.phase_mask)).astype(np.int64)

    def phases(self, count: int) -> np.ndarray:
        """The words the table is read at for the first ``count`` samples after reset: the
        accumulator plus the trim, modulo 2**phase_bits."""
        # uint64 wraps modulo 2**64, a multiple of 2**phase_bits: the low phase_bits bits are exact
        n = np.arange(count, dtype=np.uint64)
        start = np.uint64((self.phase0 + self.trim) & self.phase_mask)
        return ((start + n * np.uint64(self.ftw)) & np.uint64(self.phase_mask)).astype(np.int64)

    def wave(self, phases: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(cos, -sin) stored on nco_format for each accumulator word (the RTL's nco outputs)."""
        return _nco_waves(np.asarray(phases, dtype=np.int64), self.addr_shift, self.lut_bits, self.interp_bits,
                          self.qsin, self.two_pi, self.corr_shift, self.rules.rounding_code)

    def bin_phase(self, phases: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(bin-centre angle, interpolation offset) in radians, unquantised: the phase the NCO
        really evaluates, for the budget's phase-only source."""
        phases = np.asarray(phases, dtype=np.int64)
        a = phases >> self.addr_shift
        r = (phases >> (self.addr_shift - self.interp_bits)) & ((1 << self.interp_bits) - 1)
        step = 2 * np.pi / 2**self.lut_bits
        return (a + 0.5) * step, (2 * r + 1 - 2**self.interp_bits) / 2 ** (self.interp_bits + 1) * step


def cordic_vector(i: np.ndarray, q: np.ndarray, dp: "DemodDatapath"):
    """CORDIC vectoring on stored integers: returns (x_final, angle) with x_final = K * |(i, q)|."""
    x, z = _cordic_kernel(i, q, dp.atan.words, dp.half_pi, dp.iterations)
    # |x| <= K * sqrt(2) * 2**(wl-1) < 2**(wl+1): the two guard bits of ``work`` always suffice
    assert x.size == 0 or np.abs(x).max() <= dp.work_format.max_int, "CORDIC guard bits exhausted"
    return x, z


def cordic_gain(iterations: int) -> float:
    return float(np.prod(np.sqrt(1.0 + 2.0 ** (-2.0 * np.arange(iterations)))))


def mixer_format(in_format: Format, nco: Nco) -> Format:
    """The exact product x * nco, read one fraction bit coarser: 2 x nco (I and Q are amplitudes)."""
    fmt = product_format(in_format, nco.nco_format)
    return fmt.with_fl(fmt.fl - 1)


@dataclass(frozen=True, eq=False)
class CordicWords:
    """The vectoring CORDIC's words for one data and angle format (the demodulator's and the drive
    loop's: one description)."""

    work_format: Format   # x, y: data_format and two guard bits
    amp_format: Format    # work x 1/K
    half_pi: int          # pre-rotation angle on angle_format
    inv_k: int            # 1/K on INV_K_FORMAT
    atan: Rom             # arctan(2**-j) on angle_format


def cordic_words(name: str, data_format: Format, angle_format: Format, iterations: int) -> CordicWords:
    """The words of ``iterations`` steps, each constant quantised half_up; ValueError naming
    ``name``'s field for an iteration count or an angle format the CORDIC cannot use."""
    if not 4 <= iterations <= 40:
        raise InputError(f"{name}.cordic_iterations: must be 4..40, got {iterations}")
    if angle_format.int_bits < 2:
        raise InputError(f"{name}.angle_format: {angle_format} cannot hold +-pi radians")
    exact = Rules("half_up", "saturate")
    work = Format(True, data_format.wl + 2, data_format.fl)
    return CordicWords(
        work_format=work, amp_format=product_format(work, INV_K_FORMAT),
        half_pi=int(quantize([np.pi / 2], angle_format, exact)[0]),
        inv_k=int(quantize([1.0 / cordic_gain(iterations)], INV_K_FORMAT, exact)[0]),
        atan=Rom(quantize(np.arctan(2.0 ** -np.arange(iterations)), angle_format, exact), angle_format.wl))


@dataclass(frozen=True, eq=False)
class DemodDatapath(Datapath):
    """Fields in the order of the ``demod`` RTL module's parameters."""

    MODULE = "demod"
    RTL = RtlPorts(ready=True, serial=True, mac_bundle=True, aux=True, reference=True)
    LATENCY = 2

    @staticmethod
    def _mixer_operands(p: dict) -> tuple[int, int]:
        """The mixers' and the CORDIC gain's products: a max(DW, XW) bits, DW = INTERP_BITS +
        TWO_PI_W + 3, XW = max(IN_W, DATA_W + 3); b max(TWO_PI_W + 1, NCO_W, INV_K_W + max(0,
        MIX_SHIFT - AMP_SHIFT)) bits."""
        dw = p["INTERP_BITS"] + 2 + p["TWO_PI_W"] + 1
        xw = max(p["IN_W"], p["DATA_W"] + 3)
        ikw = p["INV_K_W"] + max(0, p["MIX_SHIFT"] - p["AMP_SHIFT"])
        return max(dw, xw), max(p["TWO_PI_W"] + 1, p["NCO_W"], ikw)

    @staticmethod
    def _lpf_operands(p: dict) -> tuple[int, int]:
        """The low-pass filter's products (the iir's, with its LPF_ parameters)."""
        return max(p["LPF_ACOEF_W"], p["LPF_OUT_SHIFT"] + 2), p["DATA_W"]

    @staticmethod
    def serial_cycles(p: dict, unroll: int = 1) -> int:
        """hdl/rtl/demod.v, ARCH = 1: 6 N + 30 + 3 ITERATIONS + F, N the limb products of the
        mixers' operands, F = 2 LPF_SECTIONS (7 M + 10) the two-channel serial iir's cycles (M the
        limb products of its operands): the pre-rotation and every CORDIC step take three cycles."""
        n = limbs(*DemodDatapath._mixer_operands(p))
        m = limbs(*DemodDatapath._lpf_operands(p))
        return 6 * n + 30 + 3 * p["ITERATIONS"] + 2 * p["LPF_SECTIONS"] * (7 * m + 10)

    @staticmethod
    def mac_operands(p: dict) -> tuple[int, int]:
        """The mixers, the CORDIC gain and the low-pass filter's products on the one bundle."""
        (a, b), (fa, fb) = DemodDatapath._mixer_operands(p), DemodDatapath._lpf_operands(p)
        return max(a, fa), max(b, fb)

    in_w: int
    data_w: int
    phase_bits: int
    lut_bits: int
    lut_w: int
    interp_bits: int         # phase bits below the table address that drive the interpolation
    two_pi: int = const()    # 2 pi on TWO_PI_FORMAT
    two_pi_w: int
    corr_shift: int          # qsin x delta_code x two_pi -> table LSBs
    nco_w: int               # NCO output: lut_w + 1 (the interpolated value cannot overflow it)
    ftw: int = const()       # phase increment per sample (turns * 2**phase_bits)
    phase0: int = const()
    phase_trim: int = const()   # reference rotation, added to the accumulator before the table (the RTL
                                # folds it into its reset phase: the same words modulo 2**phase_bits)
    mix_shift: int           # exact x * nco product, read as 2 x nco, -> data_format
    rules: Rules
    lpf: IirDatapath = nested("LPF_")   # both channels' low-pass (one design)
    iterations: int
    angle_w: int
    half_pi: int = const()   # pre-rotation angle on angle_format
    inv_k: int = const()     # 1/K on INV_K_FORMAT
    inv_k_w: int
    amp_shift: int           # work x 1/K product -> data_format
    qsin: Rom                # sin over the first quadrant at bin centres, lut_format
    atan: Rom                # arctan(2**-j) on angle_format
    addr_shift: int = info()     # LUT address = phase >> addr_shift (truncation)
    phase_mask: int = info()
    data_format: Format = info()
    work_format: Format = info()     # CORDIC x, y: data_format and two guard bits
    amp_format: Format = info()      # work x 1/K
    ovf: tuple = info()


@dataclass(frozen=True, eq=False)
class DemodRefDatapath(DemodDatapath):
    """A demodulator whose reference is an input (``reference = "input"``: the drive loop's NCO):
    the same arithmetic without its accumulator (demod.v REF = 1: the model's input ``ref`` is the
    port ``ref_phase``, ``ref`` being a SystemVerilog keyword)."""

    RTL = dataclasses.replace(DemodDatapath.RTL, names=(("ref", "ref_phase"),))
    ref: int = 1             # REF: the table at the ref input's word (FTW and PHASE0 not read)


REFERENCES = ("nco", "input")   # the demodulator's own accumulator, or the accumulator words of an input


class Demod(Block):
    """Synchronous demodulator: NCO, two mixers, two ``Iir`` low-passes and a CORDIC; ``x`` ->
    ``i``, ``q``, ``amp``, ``phase`` (module docstring)."""

    name = "demod"

    def __init__(self, nco: Nco, in_format: Format, data_format: Format, lpf_i: Iir, lpf_q: Iir,
                 angle_format: Format, cordic_iterations: int, rules: Rules, reference: str = "nco"):
        if lpf_i.data_format != data_format:
            raise InputError(f"demod.lpf.data_format: must equal demod.data_format {data_format}")
        cordic = cordic_words("demod", data_format, angle_format, cordic_iterations)
        if nco.rules.rounding != rules.rounding:
            # the bit-exact mixer rounds the NCO correction by ``rules`` (its datapath), the NCO's own
            # ``wave`` (budget, tests) by ``nco.rules``: they must be one rounding
            raise InputError(f"demod.rounding: the NCO rounds its correction by {nco.rules.rounding!r}, "
                             f"the demodulator by {rules.rounding!r}; they must be the same")
        if reference not in REFERENCES:
            raise InputError(f"demod.reference: one of {', '.join(REFERENCES)}, got {reference!r}")
        self.nco, self.reference_source = nco, reference
        self.in_format, self.data_format, self.angle_format = in_format, data_format, angle_format
        self.lpf_i, self.lpf_q = lpf_i, lpf_q
        self.rules = rules
        self.iterations = cordic_iterations
        self.mix_format = mixer_format(in_format, nco)
        self.work_format = cordic.work_format
        self.inv_k = cordic.inv_k
        lpf = lpf_i.datapath
        lpf_ovf = lambda ch: tuple(OvfField(f"lpf_{ch}.{f.counter}", f.width) for f in lpf.ovf)  # noqa: E731
        self.datapath = (DemodRefDatapath if reference == "input" else DemodDatapath)(
            in_w=in_format.wl, data_w=data_format.wl, phase_bits=nco.phase_bits, lut_bits=nco.lut_bits,
            lut_w=nco.lut_format.wl, interp_bits=nco.interp_bits, two_pi=nco.two_pi, two_pi_w=TWO_PI_FORMAT.wl,
            corr_shift=nco.corr_shift, nco_w=nco.nco_format.wl, ftw=nco.ftw, phase0=nco.phase0,
            phase_trim=nco.trim, mix_shift=self.mix_format.fl - data_format.fl,
            rules=rules, lpf=lpf, iterations=cordic_iterations, angle_w=angle_format.wl,
            half_pi=cordic.half_pi, inv_k=cordic.inv_k, inv_k_w=INV_K_FORMAT.wl,
            amp_shift=cordic.amp_format.fl - data_format.fl, qsin=Rom(nco.qsin, nco.lut_format.wl), atan=cordic.atan,
            addr_shift=nco.addr_shift, phase_mask=nco.phase_mask, data_format=data_format,
            work_format=cordic.work_format, amp_format=cordic.amp_format,
            ovf=(OvfField("mix_i", 1), OvfField("mix_q", 1), *lpf_ovf("i"), *lpf_ovf("q"), OvfField("amp", 1)))
        # ref: the accumulator words of the reference (turns), read in place of the demodulator's own
        self.inputs = {"x": in_format, **({"ref": nco.phase_format} if reference == "input" else {})}
        self.outputs = {"i": data_format, "q": data_format, "amp": data_format, "phase": angle_format}

    @classmethod
    def from_config(cls, sec: Section, fs_hz: float, in_format: Format, connect: bool = True,
                    phase_bits: int | None = None) -> "Demod":
        """``phase_bits``: the width of the reference a chain wires to ``ref`` (a drive loop's
        accumulator), else the table's own."""
        nco = Nco(fs_hz, sec.number("f_hz", low=0, low_open=True),
                  phase_bits or sec.integer("phase_bits", low=4, high=48),
                  sec.integer("lut_bits", low=4, high=20), sec.format("lut_format"),
                  sec.number("phase_offset_turns", 0.0), sec.integer("interp_bits", low=0, high=24), sec.rules(),
                  sec.number("phase_trim_rad", 0.0, low=-np.pi, high=np.pi), sec.path)
        data_format = sec.format("data_format")
        lpf_sec = sec.sub("lpf")
        lpf_format = lpf_sec.wired_format("data_format", data_format, sec.field("data_format"), connect)
        lpf_i = Iir.from_config(lpf_sec, fs_hz, lpf_format, name=f"{sec.path}.lpf_i")
        lpf_q = Iir(lpf_i.sos, lpf_i.data_format, lpf_i.num_format, lpf_i.den_format, lpf_i.rules,
                    name=f"{sec.path}.lpf_q", dc_exact=lpf_i.dc_exact, error_feedback=lpf_i.error_feedback)
        return cls(nco, in_format, data_format, lpf_i, lpf_q, sec.format("angle_format"),
                   sec.integer("cordic_iterations", low=4, high=40), sec.rules(),
                   sec.choice("reference", REFERENCES, "nco"))

    def reset(self) -> None:
        self.nco.reset()
        self.lpf_i.reset()
        self.lpf_q.reset()

    def get_state(self) -> dict:
        """The NCO phase accumulator and both low-pass filters' states."""
        return {"phase": int(self.nco.phase), "lpf_i": self.lpf_i.get_state(), "lpf_q": self.lpf_q.get_state()}

    def set_state(self, state) -> None:
        if not isinstance(state, dict) or set(state) != {"phase", "lpf_i", "lpf_q"}:
            raise InputError(f"{self.name}: state: expected a previous result's state {{'phase', 'lpf_i', 'lpf_q'}}")
        self.nco.phase = int(state["phase"]) & self.datapath.phase_mask
        self.lpf_i.set_state(state["lpf_i"])
        self.lpf_q.set_state(state["lpf_q"])

    def _ref(self, x, ref) -> np.ndarray:
        """The reference words of a run: the input's (reference = "input"), else none."""
        if self.reference_source == "nco":
            if ref is not None:
                raise InputError(f"{self.name}: ref: this demodulator runs its own NCO (reference = \"nco\")")
            return np.empty(0, dtype=np.int64)
        if ref is None or np.shape(ref) != np.shape(x):
            raise InputError(f"{self.name}: ref: one reference word per sample of x expected")
        return np.asarray(ref, dtype=np.int64)

    def mix(self, log: OverflowLog, x: np.ndarray, ref=None) -> tuple[np.ndarray, np.ndarray]:
        dp, counts = self.datapath, np.zeros(2, dtype=np.int64)
        i, q, self.nco.phase = _mix_kernel(x, self.nco.phase, dp.ftw, dp.phase_trim, dp.phase_mask, dp.addr_shift,
                                           dp.lut_bits, dp.interp_bits, dp.qsin.words, dp.two_pi, dp.corr_shift,
                                           dp.mix_shift, dp.rules.rounding_code,
                                           dp.data_format.min_int, dp.data_format.max_int, dp.rules.overflow_code,
                                           counts, self._ref(x, ref))
        log.add(f"{self.name}.{dp.ovf[0].counter}", int(counts[0]))
        log.add(f"{self.name}.{dp.ovf[1].counter}", int(counts[1]))
        return i, q

    def iq(self, log: OverflowLog, x: np.ndarray, ref=None) -> tuple[np.ndarray, np.ndarray]:
        """Mixers and low-pass filters: the rate (I) and quadrature (Q) channels."""
        i, q = self.mix(log, x, ref)
        return self.lpf_i.stream(log, x=i)["y"], self.lpf_q.stream(log, x=q)["y"]

    def stream(self, log: OverflowLog, x: np.ndarray, ref=None) -> dict[str, np.ndarray]:
        i, q = self.iq(log, x, ref)
        amp, phase = self.polar(log, i, q)
        return {"i": i, "q": q, "amp": amp, "phase": phase}

    def stream_outputs(self, log: OverflowLog, wanted: set[str], x: np.ndarray, ref=None) -> dict[str, np.ndarray]:
        """Without amp or phase wanted, the CORDIC does not run (nor count)."""
        if wanted <= {"i", "q"}:
            i, q = self.iq(log, x, ref)
            return {"i": i, "q": q}
        return self.stream(log, x=x, ref=ref)

    def polar(self, log: OverflowLog, i: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        dp = self.datapath
        xk, z = cordic_vector(i, q, dp)
        amp = resize(xk * dp.inv_k, dp.amp_format, dp.data_format, dp.rules, log, f"{self.name}.{dp.ovf[-1].counter}")
        return amp, z

    def reference(self, x: np.ndarray, ref=None) -> dict[str, np.ndarray]:
        """Pure: sample k has the NCO phase of the k-th sample after reset, on every call; with an
        external reference, the phase ``ref`` (real, in turns) plus the unquantised trim."""
        import scipy.signal as sps

        if self.reference_source == "input":   # real values: the reference's phase in turns
            if ref is None or np.shape(ref) != np.shape(x):
                raise InputError(f"{self.name}: ref: one reference phase per sample of x expected")
            ph = 2 * np.pi * np.asarray(ref, dtype=float) + self.nco.phase_trim_rad
        else:
            self._ref(x, ref)
            ph = self.nco.reference_phase(len(x), 0)
        i = sps.sosfilt(self.lpf_i.sos, 2 * x * np.cos(ph))
        q = sps.sosfilt(self.lpf_q.sos, -2 * x * np.sin(ph))
        return {"i": i, "q": q, "amp": np.hypot(i, q), "phase": np.arctan2(q, i)}

    def carrier(self, amplitude, phase_rad, count: int, start: int = 0) -> np.ndarray:
        """A sense-pick-off-like input: amplitude * cos(drive phase + phase_rad), real valued (the
        drive, not the trimmed reference)."""
        return np.asarray(amplitude) * np.cos(self.nco.drive_phase(count, start) + np.asarray(phase_rad))

    def nominal_stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        """A carrier at 0.5 FS whose phase steps through the four quadrants, plus noise."""
        n = max(n, 4096)
        phase = np.repeat(np.array([0.3, 2.0, -2.5, -0.8]), -(-n // 4))[:n]
        amp = 0.5 * self.in_format.max_value
        x = self.carrier(amp, phase, n) + rng.normal(0, 0.01 * amp, n)
        return {"x": quantize(x, self.in_format, Rules("half_up", "saturate")), **self._own_ref(n)}

    def _own_ref(self, n: int) -> dict[str, np.ndarray]:
        """An external reference's stimulus: the words its own accumulator would give (so the vectors
        equal those of a demodulator running its NCO)."""
        return {"ref": self.nco.accumulator(n)} if self.reference_source == "input" else {}

    def stimulus(self, rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
        fi = self.in_format
        full = self.carrier(1.0, 0.0, 512) * fi.max_value * 1.05  # clipped: saturating carrier
        parts = [np.tile(corner_codes(fi), 16), quantize(full, fi, Rules("half_up", "saturate")),
                 np.full(512, fi.min_int, np.int64), self.nominal_stimulus(rng, n)["x"]]
        x = np.concatenate(parts)
        return {"x": x, **self._own_ref(x.size)}

    def parameters(self) -> dict:
        return {"fs_hz": self.nco.fs_hz, "f_hz": self.nco.f_hz, "ftw": self.nco.ftw, "phase0": self.nco.phase0,
                "phase_bits": self.nco.phase_bits, "lut_bits": self.nco.lut_bits, "lut_format": str(self.nco.lut_format),
                "interp_bits": self.nco.interp_bits,
                "in_format": str(self.in_format), "data_format": str(self.data_format),
                "angle_format": str(self.angle_format), "cordic_iterations": self.iterations, "inv_k": self.inv_k,
                "rounding": self.rules.rounding, "overflow": self.rules.overflow,
                "lpf": self.lpf_i.parameters(),
                # only when set: a config without the trim records what it always did
                **({"phase_trim_rad": self.nco.phase_trim_rad, "phase_trim": self.nco.trim}
                   if self.nco.phase_trim_rad else {}),
                **({"reference": self.reference_source} if self.reference_source != "nco" else {})}
