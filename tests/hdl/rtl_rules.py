"""Static check of the RTL rounding rule: every rounding goes through the shared primitive.

The rule (hdl/README.md): ``fx_round`` is the ONE round-by-shift primitive; ``fx_convert`` (= fx_round
then fx_fit) and ``fx_convert_reg`` (fx_convert + output register) are compositions with no arithmetic
of their own; ``fx_fit`` is the one range-fit primitive. No other module may round, i.e.

* drop low bits of a data value: a right shift (``>>``, ``>>>``), a division or modulo, or a
  part-select that does not start at bit 0 (``v[H:L]`` with L != 0, ``v[B +: W]`` with B != 0,
  ``v[M -: W]``);
* build a rounding constant: a power of two from a constant one (``1 << (S-1)``, ``one <<< n``,
  ``2 ** n``), a concatenation that places a 1 above zeros (``{{..{1'b0}}, 1'b1, {(S-1){1'b0}}}``)
  or ends in an all-ones mask (``{S{1'b1}}``, the toward_zero 2**S - 1), or a single data bit
  zero-extended into an operand (the half_even odd bit, a sticky bit ``|v[S-1:0]``);
* hard-wire a rounding mode: every ``.ROUNDING(...)`` connection must name a ``*ROUNDING`` parameter
  of the module, and every module with a ``*ROUNDING`` parameter must pass it on to an instance
  whose module reaches ``fx_round``.

The Verilog is read, not grepped: comments and strings are stripped, the text is split into module
bodies, tokenised, and each construct is judged from its tokens (operands of a shift, elements of a
concatenation, whether a ``[...]`` is a declared range or a select, whether an identifier is a
parameter). Compile-time arithmetic is not data: shifts and selects of parameters, expressions
inside ``[...]`` (array sizes, indices) and parameter defaults are not judged. A few constructs that
drop bits by the *algorithm's* definition (CORDIC micro-rotation shifts, the NCO's LUT address) are
listed in :data:`ALLOWED` with the reason; an allowance that no longer matches exactly as often as
listed is itself a violation, so the list cannot go stale or hide a second use.
"""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

# modules allowed to build rounding constants / drop bits: the shared primitives
ROUND_PRIMITIVE = "fx_round"
FIT_PRIMITIVE = "fx_fit"   # builds its clamp bounds as powers of two; must not round
SHARED_ROUNDING = ("fx_round", "fx_convert", "fx_convert_reg")

# (module, rule, construct as normalised text) -> (count, reason)
ALLOWED: dict[tuple[str, str, str], tuple[int, str]] = {
    # the unrolled CORDIC (demod and drive at ARCH = 0): twice each; the serial demod (ARCH = 1, one
    # shifter for x and y): sh_in once
    ("cordic_vector", "right-shift", "cy>>>j"): (
        2, "CORDIC micro-rotation: floor shift by definition (blocks.demod.cordic_vector)"),
    ("cordic_vector", "right-shift", "cx>>>j"): (
        2, "CORDIC micro-rotation: floor shift by definition (blocks.demod.cordic_vector)"),
    ("demod", "right-shift", "sh_in>>>j"): (
        1, "CORDIC micro-rotation of x, then y, on one shifter: floor shift by definition (blocks.demod.cordic_vector)"),
    ("cordic_vector", "select", "atan_flat[ANGLE_W*j+:ANGLE_W]"): (1, "field of the flat arctan table, not a value"),
    ("drive", "right-shift", "adv_p>>>ADVANCE_BITS"): (
        2, "the carrier's advance, a phase offset: floor by definition (blocks.drive: (ftw * adv) >> advance_bits); "
           "once per architecture"),
    # the NCO phase word's fields, read by nco.v and the serial demod (ARCH = 1) through nco_phase
    ("nco_phase", "select", "phase[PHASE_BITS-1-:2]"): (1, "quadrant = top two phase bits (model: Nco bin, a >> (L - 2))"),
    ("nco_phase", "select", "phase[PHASE_BITS-3-:QBITS]"): (
        1, "quarter-table index = the next L - 2 phase bits (model: a & qmask)"),
    ("nco_phase", "select", "phase[PHASE_BITS-LUT_BITS-1-:INTERP_BITS]"): (
        1, "interpolation offset = the interp_bits below the bin; the bits below are the residual phase error "
           "(model: _nco_wave r)"),
    ("rtd", "select", "u[ADC_W-1:S]"): (1, "LUT index; the low bits are kept as the interpolation fraction"),
    ("sf_divide", "constant", "{1'b0,{(OUT_W-1){1'b1}}}"): (1, "x / 0 result: positive full scale (a value, never added)"),
    ("sf_divide", "constant", "{1'b1,{(OUT_W-1){1'b0}}}"): (1, "x / 0 result: negative full scale (a value, never added)"),
    ("piecewise", "data-bit", "{{(SEG_W-1){1'b0}},le_n[i]}"): (1, "segment number = count of breakpoint comparators"),
    ("fx_mac_serial", "select", "a_x[LIMB*ia+:LIMB]"): (
        1, "16-bit limb of an operand of the exact serial product: every limb is multiplied, no bit dropped"),
    ("fx_mac_serial", "select", "b_x[LIMB*jb+:LIMB]"): (
        1, "16-bit limb of an operand of the exact serial product: every limb is multiplied, no bit dropped"),
    # the serial iir's channel slices of its multi-channel x (channel c in bits c DATA_W ..)
    ("iir", "select", "x[DATA_W+:(NA-1)*DATA_W]"): (1, "the input channels 1 .. NA - 1 of the first pass, not a value"),
    ("iir", "select", "x[CH_LAST_I*DATA_W+:DATA_W]"): (1, "the last channel's input (SPLIT), not a value"),
    ("fx_fit", "select", "xe[W-2:TOP]"): (
        1, "the bits above the format, tested for all-sign (the range test); never kept as a value"),
    ("fx_mac_serial", "right-shift", "acc>>>LIMB"): (
        1, "carry of a completed column of the exact serial product: its low 16 bits are stored in p first"),
}

DECL_KW = {"input", "output", "inout", "wire", "reg", "integer", "localparam", "parameter", "genvar", "signed",
           "unsigned", "function", "tri", "logic", "real"}

_TOKEN = re.compile(r"""
    (?P<num>\d*\s*'[sS]?[bBoOdDhH]\s*[0-9a-fA-F_xXzZ?]+ | \d[\d_]*(?:\.\d+)?)
  | (?P<id>[$`]?[A-Za-z_][\w$]*)
  | (?P<op><<<|>>>|<<|>>|\*\*|\+:|-:|<=|>=|===|!==|==|!=|&&|\|\||[-+*/%&|^~!<>?:=;,.\#@(){}\[\]])
""", re.X)


@dataclass
class Tok:
    kind: str
    text: str


@dataclass
class Module:
    name: str
    file: str
    tokens: list[Tok]


def strip_comments(text: str, strings: bool = False) -> str:
    """Remove // and /* */ comments and string contents (kept as "" so token positions stay sane;
    ``strings``: kept as written)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            i = n if j < 0 else j + 2
            out.append(" ")
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(text[i:j + 1] if strings else '""')
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def tokenize(text: str) -> list[Tok]:
    toks = []
    for m in _TOKEN.finditer(text):
        kind = m.lastgroup
        toks.append(Tok(kind, re.sub(r"\s+", "", m.group(kind))))
    return toks


def modules_of(path: Path) -> list[Module]:
    toks = tokenize(strip_comments(path.read_text()))
    mods, i = [], 0
    while i < len(toks):
        if toks[i].text == "module":
            j = i + 1
            while j < len(toks) and toks[j].text != "endmodule":
                j += 1
            mods.append(Module(toks[i + 1].text, path.name, toks[i + 2:j]))
            i = j
        i += 1
    return mods


def literal_value(text: str) -> int | None:
    """Integer value of a Verilog number, None when it has x/z bits or is not a number."""
    m = re.fullmatch(r"(\d*)'[sS]?([bBoOdDhH])([0-9a-fA-F_xXzZ?]+)", text)
    if m:
        digits = m.group(3).replace("_", "")
        if re.search(r"[xXzZ?]", digits):
            return None
        return int(digits, {"b": 2, "o": 8, "d": 10, "h": 16}[m.group(2).lower()])
    if re.fullmatch(r"\d[\d_]*", text):
        return int(text.replace("_", ""))
    return None


def _text(toks) -> str:
    return "".join(t.text for t in toks)


_OPEN = {"(": ")", "[": "]", "{": "}"}
_CLOSE = {v: k for k, v in _OPEN.items()}


def _match(toks, i, partner: dict, step: int) -> int:
    """Index of the bracket matching the one at i, searching in direction ``step``."""
    depth, want = 0, toks[i].text
    j = i
    while 0 <= j < len(toks):
        if toks[j].text == want:
            depth += 1
        elif toks[j].text == partner[want]:
            depth -= 1
            if depth == 0:
                return j
        j += step
    raise ValueError(f"unbalanced {want}")


def _match_forward(toks, i) -> int:
    """Index of the bracket closing the one at i."""
    return _match(toks, i, _OPEN, 1)


def _match_back(toks, i) -> int:
    """Index of the bracket opening the one closed at i."""
    return _match(toks, i, _CLOSE, -1)


def _operand_before(toks, i) -> int:
    """Start index of the primary ending just before token i (identifier with selects, literal,
    parenthesised group, concatenation)."""
    j = i - 1
    while j >= 0 and toks[j].text in _CLOSE:
        k = _match_back(toks, j)
        if toks[j].text == "]" and k > 0:  # a select: keep walking to its identifier
            j = k - 1
            continue
        if toks[j].text == ")" and k > 0 and toks[k - 1].kind == "id" and toks[k - 1].text.startswith("$"):
            return k - 1  # $signed(...)
        return k
    return max(j, 0)


def _operand_after(toks, i) -> int:
    """End index (inclusive) of the primary starting at token i."""
    j = i
    while j < len(toks) and toks[j].text in ("-", "~", "!", "+"):  # unary
        j += 1
    if toks[j].kind == "id" and toks[j].text.startswith("$") and j + 1 < len(toks) and toks[j + 1].text == "(":
        return _match_forward(toks, j + 1)
    if toks[j].text in _OPEN:
        return _match_forward(toks, j)
    while j + 1 < len(toks) and toks[j + 1].text == "[":
        j = _match_forward(toks, j + 1)
    return j


def _split_top(toks, sep=",") -> list[list[Tok]]:
    parts, cur, depth = [], [], 0
    for t in toks:
        if t.text in _OPEN:
            depth += 1
        elif t.text in _CLOSE:
            depth -= 1
        if t.text == sep and depth == 0:
            parts.append(cur)
            cur = []
        else:
            cur.append(t)
    parts.append(cur)
    return parts


class _Body:
    def __init__(self, mod: Module):
        self.mod = mod
        self.t = mod.tokens
        self.consts = self._constants()
        self.ones: set[str] = set()
        self.ones = self._one_valued() - self.consts  # wires holding a constant one (not parameters)
        self.bracket_depth = self._depths()
        self.in_param_decl = self._param_decl_tokens()

    def _constants(self) -> set[str]:
        """Names declared as parameter / localparam / genvar (compile-time values, not data)."""
        names, t = set(), self.t
        for i, tok in enumerate(t):
            if tok.text in ("parameter", "localparam"):
                j = i + 1
                while j < len(t) and t[j].text != "=":
                    j += 1
                if j < len(t) and t[j - 1].kind == "id":
                    names.add(t[j - 1].text)
            elif tok.text == "genvar":
                j = i + 1
                while j < len(t) and t[j].text != ";":
                    if t[j].kind == "id":
                        names.add(t[j].text)
                    j += 1
        return names

    def _one_valued(self) -> set[str]:
        """Identifiers declared/assigned a constant equal to one (e.g. ``one = {{(W-1){1'b0}}, 1'b1}``)."""
        names, t = set(), self.t
        for i in range(1, len(t) - 1):
            if t[i].text == "=" and t[i - 1].kind == "id":
                end = i + 1
                while end < len(t) and t[end].text not in (";", ","):
                    if t[end].text in _OPEN:
                        end = _match_forward(t, end)
                    end += 1
                if self.const_value(t[i + 1:end]) == 1:
                    names.add(t[i - 1].text)
        return names

    def _param_decl_tokens(self) -> set[int]:
        """Indices of the tokens of parameter / localparam declarations (their defaults are
        configuration, not arithmetic on data)."""
        t, inside = self.t, set()
        for i, tok in enumerate(t):
            if tok.text in ("parameter", "localparam"):
                depth, j = 0, i
                while j < len(t):
                    x = t[j].text
                    if x in _OPEN:
                        depth += 1
                    elif x in _CLOSE:
                        depth -= 1
                        if depth < 0:
                            break
                    elif (x == ";" or x == ",") and depth == 0:
                        break
                    inside.add(j)
                    j += 1
        return inside

    def _depths(self) -> list[int]:
        d, out = 0, []
        for tok in self.t:
            if tok.text == "[":
                d += 1
            out.append(d)
            if tok.text == "]":
                d -= 1
        return out

    # ---- constant evaluation of concatenations --------------------------------------------
    def const_value(self, toks) -> int | None:
        """Value of a fully constant operand (literal, or concatenation of literals / replications
        of literals, with parameter-width replications treated symbolically), else None."""
        shape = self.concat_shape(toks)
        if shape is None:
            return None
        bits = [b for b, _ in shape]
        if any(b in ("D", "B") for b in bits):
            return None
        if all(b == "0" for b in bits):
            return 0
        if bits[-1] == "1" and all(b == "0" for b in bits[:-1]) and shape[-1][1] == 1:
            return 1
        return -1  # constant, some other value

    @staticmethod
    def literal_shape(text: str) -> list[tuple[str, int | None]]:
        v = literal_value(text)
        w = re.match(r"(\d+)'", text)
        width = int(w.group(1)) if w else None
        if v is None:
            return [("D", width)]
        if v == 0:
            return [("0", width)]
        if width and v == (1 << width) - 1:
            return [("1", width)]                       # all ones (1'b1 included)
        if v & (v - 1) == 0:                            # a power of two: 0..0 1 0..0
            k = v.bit_length() - 1
            head = [("0", width - k - 1)] if width and width > k + 1 else []
            return head + [("1", 1)] + ([("0", k)] if k else [])
        return [("D", width)]                           # another constant: not a rounding shape

    def concat_shape(self, toks) -> list[tuple[str, int | None]] | None:
        """Elements of an operand from MSB to LSB as ("0" | "1" | "D" | "B", width): a run of zero
        bits, of one bits, data, or a single data bit. None when it is not a literal/concat/select."""
        if not toks:
            return None
        if len(toks) == 1 and toks[0].kind == "num":
            return self.literal_shape(toks[0].text)
        if toks[0].text == "{" and _match_forward(toks, 0) == len(toks) - 1:
            inner = toks[1:-1]
            # replication {N{...}}: N then one braced group
            parts = _split_top(inner)
            if len(parts) == 1 and parts[0] and parts[0][-1].text == "}":
                k = _match_back(parts[0], len(parts[0]) - 1)
                if k > 0:
                    rep = self.concat_shape(parts[0][k:])
                    if rep is None:
                        return [("D", None)]
                    kinds = {b for b, _ in rep}
                    if kinds == {"0"}:
                        return [("0", None)]
                    if kinds == {"1"}:
                        return [("1", None)]
                    return [("D", None)]
            out = []
            for p in parts:
                sub = self.concat_shape(p)
                out.extend(sub if sub is not None else [("D", None)])
            return out
        # a single bit of a data vector: v[i] (no range)
        if toks[0].kind == "id" and len(toks) >= 4 and toks[1].text == "[" and _match_forward(toks, 1) == len(toks) - 1:
            sel = toks[2:-1]
            if not any(t.text in (":", "+:", "-:") for t in sel) and toks[0].text not in self.consts:
                return [("B", 1)]
        if toks[0].kind == "id" and len(toks) == 1 and toks[0].text in self.ones:
            return [("1", 1)]
        return [("D", None)]

    # ---- the rules --------------------------------------------------------------------------
    def is_decl_range(self, i: int) -> bool:
        """Is the '[' at i a declared range (packed or unpacked dimension), not a select?"""
        t = self.t
        p = i - 1
        while p >= 0 and t[p].text == "]":
            p = _match_back(t, p) - 1
        if p < 0:
            return True
        if t[p].text in DECL_KW:
            return True
        if t[p].kind == "id":  # unpacked dimension: the identifier is being declared
            q = p - 1
            while q >= 0 and t[q].text == "]":
                q = _match_back(t, q) - 1
            return q >= 0 and t[q].text in DECL_KW
        return False

    def violations(self) -> list[tuple[str, str]]:
        t, found = self.t, []
        for i, tok in enumerate(t):
            # right shift, division, modulo of a data value
            if tok.text in (">>", ">>>", "/", "%"):
                a = _operand_before(t, i)
                lhs = t[a:i]
                if not (len(lhs) == 1 and (lhs[0].text in self.consts or lhs[0].kind == "num")):
                    e = _operand_after(t, i + 1)
                    found.append(("right-shift" if tok.text.startswith(">") else "divide", _text(t[a:e + 1])))
            # powers of two from a constant one
            if tok.text in ("<<", "<<<", "**") and self.bracket_depth[i] == 0:
                a = _operand_before(t, i)
                lhs = t[a:i]
                base = self.const_value(lhs)
                if (tok.text == "**" and _text(lhs) == "2") or (tok.text != "**" and base == 1):
                    e = _operand_after(t, i + 1)
                    found.append(("power-of-two", _text(t[a:e + 1])))
            # a sized literal rounding constant: a power of two above 1 (16'h8000) or a multi-bit all-ones mask
            if tok.kind == "num" and "'" in tok.text and self.bracket_depth[i] == 0 and i not in self.in_param_decl \
                    and self.parent_bracket(i) != "{":
                shape = self.literal_shape(tok.text)
                kinds = [k for k, _ in shape]
                if (kinds[-1] == "0" and "1" in kinds) or (kinds == ["1"] and (shape[0][1] or 1) > 1):
                    found.append(("constant", tok.text))
            # part-selects that drop low bits (a select written to, on an assignment's left, drops nothing)
            if tok.text == "[" and i > 0 and t[i - 1].kind == "id" and not self.is_decl_range(i):
                j = _match_forward(t, i)
                sel = t[i + 1:j]
                name = t[i - 1].text
                if name not in self.consts and not self.is_lhs(i - 1, j) and self.drops_low_bits(sel):
                    found.append(("select", name + _text(t[i:j + 1])))
            # reduction of a range into a sticky bit: |v[S-1:0]
            if tok.text in ("|", "&", "^") and i + 2 < len(t) and t[i + 1].kind == "id" \
                    and t[i + 2].text == "[" and (i == 0 or t[i - 1].kind not in ("id", "num")) \
                    and t[i - 1].text not in (")", "]", "}"):
                e = _operand_after(t, i + 1)
                if any(x.text in (":", "+:", "-:") for x in t[i + 3:e]):
                    found.append(("sticky-bit", _text(t[i:e + 1])))
            # concatenations judged as a whole (an element of a bigger one is judged with it):
            # a 1 above zeros (2**n), an all-ones low mask (2**n - 1), a zero-extended data bit
            if tok.text == "{" and self.parent_bracket(i) != "{":
                j = _match_forward(t, i)
                shape = self.concat_shape(t[i:j + 1])
                kinds = [k for k, _ in shape]
                text = _text(t[i:j + 1])
                if "D" not in kinds and "B" not in kinds:
                    ones_low = kinds[-1] == "1" and shape[-1][1] != 1
                    if ones_low or (kinds[-1] == "0" and "1" in kinds):
                        found.append(("constant", text))
                elif kinds[-1] == "B" and len(kinds) > 1 and all(k == "0" for k in kinds[:-1]):
                    found.append(("data-bit", text))
        return found

    @staticmethod
    def drops_low_bits(sel) -> bool:
        rng = _split_top(sel, ":")
        if len(rng) == 2:
            return _text(rng[1]) != "0"
        if any(x.text == "-:" for x in sel):
            return True
        if any(x.text == "+:" for x in sel):
            return _text(_split_top(sel, "+:")[0]) != "0"
        return False

    def is_lhs(self, name_idx: int, close_idx: int) -> bool:
        t = self.t
        after = t[close_idx + 1].text if close_idx + 1 < len(t) else ""
        before = t[name_idx - 1].text if name_idx > 0 else ";"
        return after in ("=", "<=") and before in ("assign", ";", "begin", ")", "else", "end")

    def parent_bracket(self, i: int) -> str | None:
        """The innermost bracket still open at token i (None at statement level)."""
        t, depth = self.t, {"(": 0, "[": 0, "{": 0}
        for k in range(i - 1, -1, -1):
            x = t[k].text
            if x in _CLOSE:
                depth[_CLOSE[x]] += 1
            elif x in _OPEN:
                if depth[x] == 0:
                    return x
                depth[x] -= 1
            elif x == ";":
                return None
        return None

    # ---- routing: ROUNDING parameters reach fx_round ------------------------------------------
    def rounding_params(self) -> set[str]:
        return {n for n in self.consts if n.endswith("ROUNDING")}

    def instances(self) -> list[tuple[str, dict[str, str], bool]]:
        """(module, {port or parameter: connection text}, parameters from an `include) of every
        instance with named connections: ``mod #(...) name (...)`` or ``mod name (...)``."""
        t, out = self.t, []
        for i in range(len(t) - 3):
            if t[i].kind != "id" or (i > 0 and t[i - 1].text == "."):
                continue
            conns, via_include = {}, False
            if t[i + 1].text == "#" and t[i + 2].text == "(":
                j = _match_forward(t, i + 2)
                groups = [t[i + 3:j]]
                k = j + 1
            elif t[i + 1].kind == "id" and t[i + 2].text == "(" and t[i + 3].text == ".":
                groups, k = [], i + 1
            else:
                continue
            if not (k + 1 < len(t) and t[k].kind == "id" and t[k + 1].text == "("):
                continue
            groups.append(t[k + 2:_match_forward(t, k + 1)])
            for g in groups:
                via_include |= any(x.text == "`include" for x in g)
                for part in _split_top(g):
                    if len(part) >= 4 and part[0].text == "." and part[2].text == "(":
                        conns[part[1].text] = _text(part[3:-1])
            out.append((t[i].text, conns, via_include))
        return out


def check(rtl: Path) -> list[str]:
    """Every violation of the rounding rule in the *.v files of ``rtl``, as readable lines."""
    mods: dict[str, _Body] = {}
    problems: list[str] = []
    for path in sorted(rtl.glob("*.v")):
        found = modules_of(path)
        if [m.name for m in found] != [path.stem]:
            problems.append(f"{path.name}: must hold exactly module {path.stem}, holds {[m.name for m in found]}")
        for m in found:
            mods[m.name] = _Body(m)
    for name in SHARED_ROUNDING + (FIT_PRIMITIVE,):
        if name not in mods:
            problems.append(f"shared primitive {name} is missing")

    seen: Counter = Counter()
    for name, body in sorted(mods.items()):
        if name == ROUND_PRIMITIVE:
            continue
        for rule, text in body.violations():
            if name == FIT_PRIMITIVE and rule in ("power-of-two", "constant"):
                continue  # the fit primitive's clamp bounds
            key = (name, rule, text)
            if key in ALLOWED:
                seen[key] += 1
                continue
            problems.append(f"{body.mod.file}: {rule} `{text}` in module {name}: rounding outside fx_round")

    for key, (count, why) in ALLOWED.items():
        if key[0] in mods and seen[key] != count:
            problems.append(f"{key[0]}.v: allowed {key[1]} `{key[2]}` ({why}) expected {count}x, found {seen[key]}x")

    # routing: reaches fx_round
    reach = {ROUND_PRIMITIVE}
    changed = True
    while changed:
        changed = False
        for name, body in mods.items():
            if name not in reach and any(inst in reach for inst, _, _ in body.instances()):
                reach.add(name)
                changed = True
    for name in ("fx_convert", "fx_convert_reg"):
        if name in mods and name not in reach:
            problems.append(f"{name}.v: must be built on fx_round")
    for name, body in sorted(mods.items()):
        if name == ROUND_PRIMITIVE:
            continue
        params = body.rounding_params()
        used = set()
        for inst, conns, via_include in body.instances():
            if inst in mods and not via_include:  # every rounding mode of the instance set explicitly
                for p in sorted(mods[inst].rounding_params() - set(conns)):
                    problems.append(f"{body.mod.file}: {inst} instance leaves {p} at its default")
            for port, arg in conns.items():
                if port.endswith("ROUNDING"):
                    if arg not in params:
                        problems.append(f"{body.mod.file}: {inst} instance gets .{port}({arg}): a rounding mode "
                                        f"must come from a *ROUNDING parameter of {name}")
                    elif inst in reach:
                        used.add(arg)
        for p in sorted(params - used):
            problems.append(f"{body.mod.file}: parameter {p} of {name} never reaches a shared rounding instance")
    return problems
