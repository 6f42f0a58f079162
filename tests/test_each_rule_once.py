"""Each rule once: a scan of the source (``ast``) of rfsim/, devices/ and channels/ for copies of
the rules that have one definition.

The FM0/Miller line codes are the transition tables of :mod:`rfsim.gen2._linecode_kernels`
(``HALF_LEVELS``, ``NEXT_STATE``, ``SUBCARRIER_SIGN``); the encoder, the Viterbi trellis, the
element expansion, the reply decoders and the reader's BLF search read them there. A copy of the
rules shows in the source as one of the idioms the tables replaced: an inversion of the level
chosen by a condition (``-cur if … else cur``), a level index written as a conditional
(``0 if level == 1 else 1``), the subcarrier as every other element inverted (``x[1::2] *= -1``,
``m > 1 and k & 1``, ``k % 2 == 0``), a table of ±1 levels, or a Viterbi loop.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SCANNED = ("rfsim", "devices", "channels")
#: The one definition of the FM0/Miller rules.
LINECODE_HOME = "rfsim/gen2/_linecode_kernels.py"
#: Names of the tables of the line codes.
LINECODE_TABLES = {"HALF_LEVELS", "NEXT_STATE", "SUBCARRIER_SIGN", "LEVEL_OF_STATE", "PREV_BIT_OF_STATE"}
#: Modules that decode or encode FM0/Miller replies in compiled code: they must read the one
#: definition (import its kernels) and hold no rule of their own.
LINECODE_USERS = ("rfsim/gen2/_reply_kernels.py", "rfsim/gen2/_blf_search_kernels.py", "rfsim/gen2/linecode.py")


def _modules():
    for top in SCANNED:
        for path in sorted((ROOT / top).rglob("*.py")):
            if "__pycache__" in path.parts:
                continue
            yield path.relative_to(ROOT).as_posix(), ast.parse(path.read_text(), filename=str(path))


MODULES = dict(_modules())


#: Modules of other line codes, where a level inverted by a condition is their own rule: the
#: BOC chips of HiMR beacons (not FM0/Miller).
OTHER_LINE_CODES = ("rfsim/himr/_boc_kernels.py",)


def _is_neg_of(node: ast.AST, other: ast.AST) -> bool:
    """``node`` is ``-other`` for a variable ``other`` (a level, not a constant sign)."""
    return (isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub) and isinstance(other, ast.Name)
            and ast.dump(node.operand) == ast.dump(other))


def _const(node: ast.AST, value) -> bool:
    return isinstance(node, ast.Constant) and node.value == value and type(node.value) is type(value)


def _linecode_idioms(tree: ast.AST) -> list[str]:
    """Source idioms of a hand-written FM0/Miller rule (module docstring), as ``line: idiom``."""
    found = []
    for node in ast.walk(tree):
        line = getattr(node, "lineno", 0)
        if isinstance(node, ast.IfExp):
            # -x if cond else x  /  x if cond else -x: a level inverted by a rule
            if _is_neg_of(node.body, node.orelse) or _is_neg_of(node.orelse, node.body):
                found.append(f"{line}: level inverted by a condition")
            # 0 if level == 1 else 1: the level index of a trellis state
            if (_const(node.body, 0) and _const(node.orelse, 1) and isinstance(node.test, ast.Compare)
                    and any(_const(c, 1) for c in node.test.comparators)):
                found.append(f"{line}: level index of a trellis state")
        if isinstance(node, ast.AugAssign) and isinstance(node.op, ast.Mult) and isinstance(node.target, ast.Subscript):
            sl = node.target.slice
            if isinstance(sl, ast.Slice) and _const(sl.lower, 1) and _const(sl.step, 2):
                found.append(f"{line}: every other element inverted (subcarrier)")
        if isinstance(node, ast.BoolOp):
            text = ast.unparse(node)
            if ("m > 1" in text or "m == 1" in text) and ("& 1" in text or "% 2" in text):
                found.append(f"{line}: subcarrier sign from the element parity")
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id in LINECODE_TABLES
                                                for t in node.targets):
            found.append(f"{line}: a line-code table")
        if isinstance(node, ast.FunctionDef) and "viterbi" in node.name.lower():
            if any(isinstance(n, (ast.For, ast.While)) for n in ast.walk(node)):
                found.append(f"{line}: a Viterbi loop ({node.name})")
    return found


def test_linecode_home_holds_the_rules():
    """The scan finds the rules where they are defined (so it can find a copy elsewhere)."""
    found = _linecode_idioms(MODULES[LINECODE_HOME])
    assert any("line-code table" in f for f in found)
    assert any("Viterbi loop" in f for f in found)


@pytest.mark.parametrize("module", sorted(m for m in MODULES if m not in (LINECODE_HOME, *OTHER_LINE_CODES)))
def test_no_other_module_defines_fm0_miller_rules(module):
    """No module but the home of the tables writes an FM0/Miller rule, a level table or a Viterbi."""
    assert _linecode_idioms(MODULES[module]) == [], module


@pytest.mark.parametrize("module", LINECODE_USERS)
def test_linecode_users_import_the_one_definition(module):
    """The encoder, the reply decoders and the BLF search import the tables' kernels."""
    imported = set()
    for node in ast.walk(MODULES[module]):
        if isinstance(node, ast.ImportFrom) and node.module == "rfsim.gen2._linecode_kernels":
            imported |= {a.name for a in node.names}
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "lazy_import":
            if _const(node.args[0], "rfsim.gen2._linecode_kernels"):
                imported.add("*")
    assert imported, f"{module} does not import rfsim.gen2._linecode_kernels"


# ----------------------------------------------------------------- Gen2 tag state machine

#: The one definition of the rules of the Gen2 tag state machine, over arrays (a single tag is
#: a population of one): module → its rule functions.
TAG_RULES = {"devices/gen2_tag_arrays.py": ("round_step", "_round_tables", "round_row", "round_step_rows",
                                            "round_step_of_one", "query_matches", "select_step"),
             "devices/gen2_tag_values.py": ("adjusted_q",),
             "devices/_gen2_tag_kernels.py": ("slot_replies", "decremented", "s1_reverts"),
             "rfsim/gen2/tag_draws.py": ("_top_bits",)}
#: Functions that the scan below does not read: the rules, and the dispatch of the access
#: commands (Req_RN in Acknowledged, the others in Open/Secured), whose one definition is
#: :mod:`rfsim.gen2.access` and which a tag always takes through its own path.
TAG_SCAN_SKIP = {**TAG_RULES, "devices/gen2_tag_state.py": ("_access_command",)}
#: The one definition of the access commands' rules (the states Open, Secured, Killed and the
#: handle check of an access), not read by the scan.
ACCESS_HOME = "rfsim/gen2/access.py"
#: Where the rules are applied, and the rule each calls: a single tag's state (its row of
#: round_step, round_step_of_one) and a population's arrays.
TAG_RULE_USERS = (("devices/gen2_tag_state.py", "_reply_if_zero", "slot_replies"),
                  ("devices/gen2_tag_state.py", "on_command_if_silent", "round_step_of_one"),
                  ("devices/gen2_tag_state.py", "_round_command", "round_step_of_one"),
                  ("devices/gen2_tag_state.py", "_query", "round_step_of_one"),
                  ("devices/gen2_tag_state.py", "_query", "query_matches"),
                  ("devices/gen2_tag_state.py", "_advance", "s1_reverts"),
                  ("devices/gen2_tag_state.py", "_select", "select_step"),
                  ("devices/gen2_tag_arrays.py", "silent_steps", "round_step_rows"),
                  ("devices/gen2_tag_arrays.py", "silent_steps", "decremented"),
                  ("devices/gen2_tag_arrays.py", "redraw_steps", "round_step_rows"),
                  ("devices/gen2_tag_arrays.py", "redraw_steps", "s1_reverts"),
                  ("devices/gen2_tag_arrays.py", "take_silent_steps", "s1_reverts"),
                  ("devices/gen2_tag_arrays.py", "take_silent_steps", "decremented"),
                  ("devices/gen2_tag_arrays.py", "take_redraw_steps", "adjusted_q"),
                  ("devices/gen2_tag_arrays.py", "take_redraw_steps", "slot_replies"),
                  ("devices/gen2_tag_arrays.py", "step_silently", "round_step_rows"),
                  # the one-pass kernel of step_silently, the counter's rules compiled into it
                  ("devices/_gen2_tag_kernels.py", "silent_step_kernel", "_decremented"),
                  ("devices/_gen2_tag_kernels.py", "silent_step_kernel", "_slot_replies"),
                  ("devices/_gen2_tag_kernels.py", "silent_step_kernel", "_s1_reverts"),
                  # the populations step their tags through the arrays' steps above
                  ("devices/gen2_tag_arrays.py", "step_silently", "take_redraw_steps"),
                  ("devices/tag_population.py", "reflect_scaled", "step_silently"),
                  ("rfsim/protocols/inventory.py", "_drive_arrays", "step_silently"))
#: The commands whose transitions ``round_step`` decides.
ROUND_COMMANDS = {"Query", "QueryRep", "QueryAdjust", "ACK", "NAK"}
#: The states of an inventory round, by name and by code.
ROUND_STATES = {"ready", "arbitrate", "reply", "acknowledged", "open", "secured"}
ROUND_STATE_CODES = {"_READY", "_ARBITRATE", "_REPLY", "_ACKNOWLEDGED", "_OPEN", "_SECURED"}
#: A Query's Sel values that select by the SL flag, and the Select table's actions by name.
SEL_VALUES = {"sl", "~sl"}
SELECT_ACTION_NAMES = {"set", "clear", "flip"}


def _function(module: str, name: str) -> ast.FunctionDef:
    found = [n for n in ast.walk(MODULES[module]) if isinstance(n, ast.FunctionDef) and n.name == name]
    assert len(found) == 1, (module, name)
    return found[0]


def _names(node: ast.AST) -> set[str]:
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}


def _is_session(node: ast.AST) -> bool:
    return (isinstance(node, ast.Name) and node.id == "session") or (
        isinstance(node, ast.Attribute) and node.attr == "session")


def _is_state(node: ast.AST) -> bool:
    """``node`` is a tag's state or state code (``state``, ``x.state``, ``code``, ``x.code``)."""
    return (isinstance(node, ast.Name) and node.id in ("state", "code")) or (
        isinstance(node, ast.Attribute) and node.attr in ("state", "code"))


def _names_a_round_state(node: ast.AST) -> bool:
    """``node`` is a round state (name or code) or a collection holding one."""
    items = node.elts if isinstance(node, (ast.Tuple, ast.List, ast.Set)) else [node]
    return any((isinstance(i, ast.Constant) and i.value in ROUND_STATES)
               or (isinstance(i, ast.Name) and i.id in ROUND_STATE_CODES) for i in items)


def _tag_rule_idioms(tree: ast.AST, skip: tuple = ()) -> list[str]:
    """Source idioms of a hand-written rule of the tag state machine, as ``line: idiom``,
    outside the functions named in ``skip``: a slot-counter decrement ``(… − 1) & 0x7FFF``, a
    comparison of a state with a round state (``state == "reply"``, ``code in (_OPEN,
    _SECURED)``), a comparison of two sessions (the round's guard), an S1 persistence test, Q
    clamped to 15, a Query's Sel compared with ``"sl"``/``"~sl"``, a Select action named
    (``"set"``, ``"clear"``, ``"flip"``), or a slot counter drawn from a word (``w >> (32 − Q)``)."""
    skipped = {id(n) for f in ast.walk(tree) if isinstance(f, ast.FunctionDef) and f.name in skip
               for n in ast.walk(f)}
    found = []
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        line = getattr(node, "lineno", 0)
        if (isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitAnd) and _const(node.right, 0x7FFF)
                and isinstance(node.left, ast.BinOp) and isinstance(node.left.op, ast.Sub)
                and _const(node.left.right, 1)):
            found.append(f"{line}: a slot-counter decrement")
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(map(_is_state, sides)) and any(map(_names_a_round_state, sides)):
                found.append(f"{line}: a state compared with a round state")
            if sum(map(_is_session, sides)) >= 2:
                found.append(f"{line}: two sessions compared (the round's guard)")
            if (any(isinstance(x, ast.BinOp) and isinstance(x.op, ast.Sub) for x in sides)
                    and "s1_" in ast.unparse(node)):
                found.append(f"{line}: an S1 persistence test")
            if any(isinstance(x, ast.Constant) and x.value in SEL_VALUES for x in sides):
                found.append(f"{line}: a Query's Sel tested")
            if any(isinstance(x, ast.Constant) and x.value in SELECT_ACTION_NAMES for x in sides):
                found.append(f"{line}: a Select action")
        if (isinstance(node, ast.BinOp) and isinstance(node.op, ast.RShift) and isinstance(node.right, ast.BinOp)
                and isinstance(node.right.op, ast.Sub) and _const(node.right.left, 32)):
            found.append(f"{line}: a slot counter drawn from a 32-bit word")
        if isinstance(node, ast.Call) and any(_const(a, 15) for a in node.args):
            name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
            if name in ("min", "max", "minimum", "maximum", "clip"):
                found.append(f"{line}: Q clamped to 15")
    return found


def test_tag_rules_home_holds_the_rules():
    """The scan finds the rules where they are defined (so it can find a copy elsewhere), and
    ``round_step`` tells every round command apart."""
    home = "devices/gen2_tag_arrays.py"
    kinds = {f.split(": ")[1] for f in _tag_rule_idioms(MODULES[home])}
    assert {"two sessions compared (the round's guard)", "a Query's Sel tested"} <= kinds, kinds
    assert [f for f in _tag_rule_idioms(MODULES["devices/gen2_tag_values.py"]) if "Q clamped" in f]
    assert [f for f in _tag_rule_idioms(MODULES["devices/_gen2_tag_kernels.py"]) if "a slot-counter decrement" in f]
    assert [f for f in _tag_rule_idioms(MODULES["devices/_gen2_tag_kernels.py"]) if "an S1 persistence test" in f]
    for module, names in TAG_SCAN_SKIP.items():
        assert _tag_rule_idioms(MODULES[module], skip=names) == [], module
    assert ROUND_COMMANDS <= _names(_function(home, "round_step"))


def test_scan_finds_the_rules_of_the_old_state_machine():
    """The scan flags the hand-written rules the functions replaced (so a copy cannot pass)."""
    old = ast.parse('''
class TagState:
    def _matches_query(self, cmd):
        if cmd.sel == "sl" and not self.sl:
            return False
        return self.inventoried[cmd.session] == cmd.target
    def _query_rep(self, cmd, rng):
        if self.session is None or cmd.session != self.session:
            return None
        if self.state == "arbitrate":
            self.slot = (self.slot - 1) & 0x7FFF
    def _advance(self, t_s):
        if t_s - self._s1_set_s >= self.persistence.s1_s:
            self.inventoried[1] = "A"
    def _select(self, todo):
        if todo == "flip":
            self.sl = not self.sl
    def _query_adjust(self, cmd, word):
        self.q = min(15, max(0, self.q + cmd.updn))
        self.slot = word() >> (32 - self.q)
''')
    kinds = {f.split(": ")[1] for f in _tag_rule_idioms(old)}
    assert kinds == {"a Query's Sel tested", "two sessions compared (the round's guard)",
                     "a state compared with a round state", "a slot-counter decrement", "an S1 persistence test",
                     "a Select action", "Q clamped to 15", "a slot counter drawn from a 32-bit word"}, kinds


def test_tag_rules_defined_once():
    """Each rule function is defined once, in its home."""
    for module, names in TAG_RULES.items():
        for name in names:
            homes = [m for m, tree in MODULES.items()
                     if any(isinstance(n, ast.FunctionDef) and n.name == name for n in ast.walk(tree))]
            assert homes == [module], (name, homes)


@pytest.mark.parametrize("module", sorted(m for m in MODULES if m != ACCESS_HOME))
def test_no_other_function_writes_a_tag_rule(module):
    """No function but the rules' own writes a rule of the state machine: a tag's state
    (TagState, PassiveTag, TagPopulation, the protocol-level air) reads the rules, it does not
    restate them."""
    assert _tag_rule_idioms(MODULES[module], skip=TAG_SCAN_SKIP.get(module, ())) == [], module


@pytest.mark.parametrize("module, name, rule", TAG_RULE_USERS)
def test_tag_rule_users_call_the_one_rule(module, name, rule):
    """A tag's and a population's steps call the one rule and name no round command themselves
    (no second copy of which command does what in which state)."""
    fn = _function(module, name)
    assert rule in _calls(fn), (name, sorted(_calls(fn)))
    named = _names_outside_dispatch(fn) & ROUND_COMMANDS
    assert not named, sorted(named)


#: The NumPy reference of StateArrays.step_silently's compiled pass (and its helpers): the tests
#: hold the pass equal to it; nothing else calls it.
SILENT_STEP_REFERENCE = {"silent_steps", "take_silent_steps", "redraw_steps", "_count_down", "_follow"}


def test_the_silent_steps_numpy_reference_has_no_caller_in_the_code():
    """The silent-step decision is applied by one compiled pass (``step_silently``); its NumPy
    twin is the tests' reference only: no module calls it, and within the arrays' module only
    the reference itself does."""
    callers = []
    for module, tree in MODULES.items():
        for fn in (n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)):
            if module == "devices/gen2_tag_arrays.py" and fn.name in SILENT_STEP_REFERENCE:
                continue
            used = _calls(fn) & SILENT_STEP_REFERENCE
            if used:
                callers.append((module, fn.name, sorted(used)))
    assert callers == []


def _names_outside_dispatch(fn: ast.AST) -> set[str]:
    """Names in ``fn`` but those of a dispatch on the command's class (``type(cmd) is X``,
    ``isinstance(cmd, X)``: which shortcut applies, not what the command does) and of its
    annotations."""
    dispatch = set()
    for n in ast.walk(fn):
        if isinstance(n, ast.arg) and n.annotation is not None:
            dispatch |= {id(x) for x in ast.walk(n.annotation)}
        if isinstance(n, ast.FunctionDef) and n.returns is not None:
            dispatch |= {id(x) for x in ast.walk(n.returns)}
        if (isinstance(n, ast.Compare) and isinstance(n.left, ast.Call) and getattr(n.left.func, "id", "") == "type"
                and all(isinstance(op, (ast.Is, ast.IsNot)) for op in n.ops)):
            dispatch |= {id(c) for c in n.comparators}
        if isinstance(n, ast.Call) and getattr(n.func, "id", "") == "isinstance":
            dispatch |= {id(x) for a in n.args[1:] for x in ast.walk(a)}
    return {n.id for n in ast.walk(fn) if isinstance(n, ast.Name) and id(n) not in dispatch}


# ----------------------------------------------------------------- tag reply decoders: shared steps

#: The home of the steps the tag-reply decoders share (:mod:`rfsim.gen2.reply_core`).
REPLY_CORE = "rfsim/gen2/reply_core.py"
REPLY_CORE_KERNELS = "rfsim/gen2/_reply_core_kernels.py"
#: Compiled code of the reader's BLF search and of the capture decoder (search, decoding).
READER_KERNELS = "rfsim/gen2/_blf_search_kernels.py"
CAPTURE_SEARCH_KERNELS = "rfsim/gen2/_reply_search_kernels.py"
CAPTURE_DECODE_KERNELS = "rfsim/gen2/_reply_kernels.py"
#: Each shared step: its home and the decoders' modules that must call it.
REPLY_STEPS = {
    "normalised_correlation": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_SEARCH_KERNELS, CAPTURE_DECODE_KERNELS)),
    "parabola_offset": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_SEARCH_KERNELS)),
    "cumulative_sums_into": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_SEARCH_KERNELS)),
    "centred_start": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_DECODE_KERNELS)),
    "fine_step": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_DECODE_KERNELS)),
    "blf_resolution": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_DECODE_KERNELS, "rfsim/gen2/blf_search.py",
                                            "rfsim/gen2/reply_decoding.py")),
    "preamble_gain_offset": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_DECODE_KERNELS)),
    "halfbit_decisions": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_DECODE_KERNELS)),
    "rest_level_sums": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_DECODE_KERNELS)),
    "steady_residual": (REPLY_CORE_KERNELS, (READER_KERNELS, CAPTURE_DECODE_KERNELS)),
    "n_pre_elements": (REPLY_CORE, ("rfsim/gen2/reply_search.py", "rfsim/gen2/reply_decoding.py")),
    "n_reply_elements": (REPLY_CORE, ("rfsim/gen2/blf_search.py", "rfsim/gen2/reply_search.py",
                                      "rfsim/gen2/reply_decoding.py", "rfsim/gen2/replies.py")),
    "coarse_blf_step": (REPLY_CORE, ("rfsim/gen2/blf_search.py", "rfsim/gen2/reply_search.py")),
    "geometric_blf_grid_hz": (REPLY_CORE, ("rfsim/gen2/blf_search.py", "rfsim/gen2/reply_search.py")),
    "preamble_template0": (REPLY_CORE, ("rfsim/gen2/blf_search.py", "rfsim/gen2/reply_search.py")),
}
#: Shared constants: the home and the decoders' modules that import it.
REPLY_CONSTANTS = {"FINE_SPAN_STEPS": (REPLY_CORE, ("rfsim/gen2/blf_search.py", "rfsim/gen2/reply_search.py",
                                                    "rfsim/gen2/reply_decoding.py"))}


def _dotted(module: str) -> str:
    """``rfsim/gen2/x.py`` → ``rfsim.gen2.x``; ``devices/x.py`` → ``rfsim.devices.x``."""
    name = module[:-3].replace("/", ".")
    return name if name.startswith("rfsim.") else f"rfsim.{name}"


def _calls(tree: ast.AST) -> set[str]:
    return {n.func.id if isinstance(n.func, ast.Name) else n.func.attr for n in ast.walk(tree)
            if isinstance(n, ast.Call) and isinstance(n.func, (ast.Name, ast.Attribute))}


def _imported_from(tree: ast.AST, module: str) -> set[str]:
    """Names imported from ``module``; ``*`` when the module is imported lazily (``lazy_import``)."""
    names = {a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module == module for a in n.names}
    if any(isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == "lazy_import"
           and _const(n.args[0], module) for n in ast.walk(tree)):
        names.add("*")
    return names


def _reply_step_idioms(tree: ast.AST) -> list[str]:
    """Source idioms of a shared reply step written out again, as ``line: idiom``: the
    correlation's |Σ z·t0| (``math.hypot``), the parabola's curvature ``c₋ − 2.0·c₀ + c₊``,
    the steady-sample test (both neighbours ``[n − 1]``, ``[n + 1]`` compared)."""
    found = []
    for node in ast.walk(tree):
        line = getattr(node, "lineno", 0)
        if isinstance(node, ast.Call) and ast.unparse(node.func) == "math.hypot":
            found.append(f"{line}: normalised correlation")
        if (isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add) and isinstance(node.left, ast.BinOp)
                and isinstance(node.left.op, ast.Sub) and isinstance(node.left.right, ast.BinOp)
                and isinstance(node.left.right.op, ast.Mult) and _const(node.left.right.left, 2.0)
                and all(isinstance(v, (ast.Name, ast.Subscript)) for v in (node.left.left, node.left.right.right,
                                                                            node.right))):
            found.append(f"{line}: parabola through three correlations")
        if isinstance(node, ast.BoolOp) and isinstance(node.op, ast.And):
            text = ast.unparse(node)
            if "[n - 1]" in text and "[n + 1]" in text and "==" in text:
                found.append(f"{line}: steady-sample test")
    return found


@pytest.mark.parametrize("name", sorted(REPLY_STEPS))
def test_reply_step_defined_once(name):
    """Each shared step of the reply decoders is defined in its home and nowhere else."""
    home = REPLY_STEPS[name][0]
    where = [m for m, tree in MODULES.items()
             if any(isinstance(n, ast.FunctionDef) and n.name == name for n in ast.walk(tree))]
    assert where == [home], where


@pytest.mark.parametrize("name, user", [(n, u) for n, (_, users) in sorted(REPLY_STEPS.items()) for u in users])
def test_reply_decoders_call_the_shared_step(name, user):
    """The reader's BLF search and the capture decoder import the step from its home and call it."""
    home = REPLY_STEPS[name][0]
    tree = MODULES[user]
    assert _imported_from(tree, _dotted(home)) & {name, "*"}, f"{user} does not import {name} from {home}"
    assert name in _calls(tree), f"{user} does not call {name}"


@pytest.mark.parametrize("name, user", [(n, u) for n, (_, users) in sorted(REPLY_CONSTANTS.items()) for u in users])
def test_reply_decoders_share_constants(name, user):
    """A constant of both decoders is assigned once, in its home, and imported by the others."""
    home = REPLY_CONSTANTS[name][0]
    assigned = [m for m, tree in MODULES.items()
                if any(isinstance(n, ast.Assign) and any(isinstance(t, ast.Name) and t.id == name for t in n.targets)
                       for n in ast.walk(tree))]
    assert assigned == [home], assigned
    assert name in _imported_from(MODULES[user], _dotted(home))


def test_reply_step_idioms_only_in_their_home():
    """The scan finds the shared steps in their home (so it can fail), and in no compiled code of
    the decoders."""
    home = _reply_step_idioms(MODULES[REPLY_CORE_KERNELS])
    assert {f.split(": ")[1] for f in home} == {"normalised correlation", "parabola through three correlations",
                                                "steady-sample test"}
    for module in (READER_KERNELS, CAPTURE_SEARCH_KERNELS, CAPTURE_DECODE_KERNELS):
        assert _reply_step_idioms(MODULES[module]) == [], module


# ----------------------------------------------------------------- the one reply decoder

#: The one tag-reply decoder (:func:`rfsim.gen2.reply_decoder.decode`) and its callers: the reader in
#: the loop, the capture decoder (``rfsim decode``) and the capture sweep's batched BLF search.
REPLY_DECODER = "rfsim/gen2/reply_decoder.py"
DECODER_CALLERS = ("devices/reader.py", "rfsim/gen2/replies.py", "rfsim/scenes/capture_sweep.py")
#: The orchestrations the decoder's searches run (each one numba call or one search function):
#: nobody but the decoder calls them, except the modules allowed here, each with its reason.
DECODER_STEPS = {
    "receive_kernel": {"rfsim/gen2/_receive_kernels.py":
                       "receive_batch_kernel, the same kernel on each window of a batch"},
    "search_decode": {},
    "_detect": {},
    "_decode_window": {},
    "search_decode_kernel": {"rfsim/gen2/blf_search.py": "search_decode, the 'blf' search's own function"},
    "decode_window_kernel": {"rfsim/gen2/reply_decoding.py": "_decode_window, the 'link' search's own function"},
    "preamble_search_kernel": {
        "rfsim/gen2/reply_search.py": "_detect, the 'link' search's own function",
        "devices/_reader_statistic_kernels.py": "the statistic receiver draws the statistics the search reads "
                                                "(another receiver model, opt-in), its search over them",
    },
    "decode_reply": {
        "rfsim/gen2/reply_decoding.py": "the plain-NumPy strategies (twins) of the 'link' search's kernels",
        "rfsim/bench/preamble.py": "the benchmark of the one-BLF step itself",
        "devices/st_rows.py": "the sense-a-tag's comparator rows: a binary comparator output, not a reader window",
        "devices/st_receiver.py": "the sense-a-tag's receiver of that comparator output",
    },
}


def _called_names(tree: ast.AST) -> set[str]:
    """Names called in ``tree`` (``f(...)`` or ``x.f(...)``), with the names they were imported as
    mapped back to the imported names."""
    alias = {a.asname: a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names if a.asname}
    return {alias.get(name, name) for name in _calls(tree)}


@pytest.mark.parametrize("caller", DECODER_CALLERS)
def test_reader_and_capture_paths_call_the_one_decoder(caller):
    """The reader in the loop, the capture decoder and the capture sweep import
    :func:`rfsim.gen2.reply_decoder.decode` (or the module, lazily) and call it."""
    tree = MODULES[caller]
    assert _imported_from(tree, _dotted(REPLY_DECODER)) & {"decode", "*"}, caller
    assert "decode" in _called_names(tree), f"{caller} does not call decode"


@pytest.mark.parametrize("step", sorted(DECODER_STEPS))
def test_no_module_runs_a_decoder_search_outside_the_decoder(step):
    """The searches of the decoder are called by the decoder (or their own function, allow-listed
    with its reason), by no other module; the scan finds the decoder's own calls, so it can fail."""
    callers = sorted(m for m, tree in MODULES.items() if step in _called_names(tree))
    assert callers, f"nobody calls {step}: the scan is broken"
    allowed = set(DECODER_STEPS[step]) | {REPLY_DECODER}
    assert set(callers) <= allowed, sorted(set(callers) - allowed)
    if not DECODER_STEPS[step]:
        assert callers == [REPLY_DECODER]


# ----------------------------------------------------------------- one orchestration, steps chosen by the plan

#: The function of each search's entry (the compiled search of its "search" or "timing" step).
SEARCH_ENTRIES = ("receive_kernel", "search_decode", "_detect", "_decode_window")


def _decoder_functions() -> dict:
    tree = MODULES[REPLY_DECODER]
    return {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}


def test_decode_runs_the_plans_steps_without_a_branch_per_search():
    """``decode`` reads no ``search`` of the plan and calls no search itself: it runs the steps
    the plan names (a per-search copy of the sequence would read ``plan.search``)."""
    body = _decoder_functions()["decode"]
    attrs = {n.attr for n in ast.walk(body) if isinstance(n, ast.Attribute)}
    assert "steps" in attrs, "decode does not run the plan's steps"
    assert "search" not in attrs
    assert not set(SEARCH_ENTRIES) & set(_calls(body))


def test_each_search_entry_is_one_step_variant():
    """Each compiled search is called by exactly one function of the decoder, and that function
    is a variant of a step in the decoder's table."""
    from rfsim.gen2 import reply_decoder as rd

    variants = {f.__name__ for table in rd.VARIANTS.values() for f in table.values()}
    for entry in SEARCH_ENTRIES:
        users = [name for name, f in _decoder_functions().items() if entry in _calls(f)]
        assert len(users) == 1 and users[0] in variants, (entry, users)


def test_plan_variants_name_a_function_of_every_step():
    from rfsim.gen2 import reply_decoder as rd
    from rfsim.gen2.reply_search import LinkHypothesis

    assert rd.STEPS == tuple(rd.VARIANTS)
    plans = [rd.DecodePlan("known", 4e6), rd.DecodePlan("blf", 4e6, refit=True),
             rd.DecodePlan("blf", 4e6, dc_from_lead=False),
             rd.DecodePlan("link", 2e6, hypotheses=(LinkHypothesis(4, False, 2e5, 3e5),), track_timing=True),
             rd.DecodePlan("known", 4e6, track_timing=True), rd.DecodePlan("blf", 4e6, track_timing=True)]
    for plan in plans:
        for step, variant, f in zip(rd.STEPS, plan.variants, plan.steps, strict=True):
            assert rd.VARIANTS[step][variant] is f, (plan.search, step, variant)
    # the fields choose the variants: the refit switches the measurement, the DC from the lead the conditioning
    assert plans[1].variants.measure == "known levels" and plans[2].variants.measure == "search fit"
    assert plans[1].variants.condition == "lead" and plans[2].variants.condition == "none"
    assert len({p.variants.search for p in plans}) == 3
    # the reader's tracking selects the capture's timing step, its decisions and measurement
    assert {p.variants[3:6] for p in plans[3:]} == {("track", "timing", "timing")}


def _reply_window(rng, m=4, blf=320e3, fs=4e6, start=300, n_bits=16):
    """A window c + h·s(t) + noise with one reply (rest level −1 around it) starting at sample
    ``start``: (r, bits, n_reply)."""
    from rfsim.gen2.linecode import reply_duration_s, reply_waveform

    bits = rng.integers(0, 2, n_bits).astype(np.uint8)
    n_reply = int(np.ceil(reply_duration_s(n_bits, m=m, trext=False, blf_hz=blf) * fs))
    n = start + 2 * n_reply + 400
    s = reply_waveform(bits, m=m, trext=False, blf_hz=blf, fs_hz=fs, t0_s=start / fs, n_samples=n)
    s[s == 0] = -1.0
    noise = 1e-5 * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    return (0.2 + 0.1j) + 1e-3 * np.exp(0.3j) * s + noise, bits, n_reply


def test_the_three_searches_run_the_same_step_list(monkeypatch):
    """A reply found by the "known", the "blf" (reader, with the refit) and the "link" (capture)
    search runs every step of ``STEPS`` in order, each once (recorded by wrapping every variant
    of the decoder's table); a window without a reply stops after the search. Fails when a
    search skips the orchestration or runs its own sequence."""
    from rfsim.bench.decode import exchange_items, synthetic_capture
    from rfsim.gen2 import reply_decoder as rd
    from rfsim.gen2.capture import decode_reader_commands
    from rfsim.gen2.link import profile
    from rfsim.gen2.replies import decode_tag_replies

    trace = []

    def wrap(step, f):
        def run(w, plan):
            trace.append(step)
            return f(w, plan)
        return run

    for step, table in rd.VARIANTS.items():
        for name, f in list(table.items()):
            monkeypatch.setitem(table, name, wrap(step, f))

    def calls():  # the recorded steps, one list per decode call
        out = []
        for step in trace:
            if step == rd.STEPS[0]:
                out.append([])
            out[-1].append(step)
        trace.clear()
        return out

    rng = np.random.default_rng(5)
    r, bits, n_reply = _reply_window(rng)
    plans = rd.LinkPlans(profile("miller4-320k"))
    out = rd.decode(r, plans.plan("known", 4e6, "viterbi", 1e-3), lo=250, hi=350, n_bits=16, n_reply=n_reply)
    assert out.found and np.array_equal(out.bits, bits)
    assert calls() == [list(rd.STEPS)]
    out = rd.decode(r, plans.plan("blf", 4e6, "viterbi", 1e-3, refit=True), lo=250, hi=350, n_bits=16)
    assert out.found and np.array_equal(out.bits, bits) and np.isfinite(out.slope)
    assert calls() == [list(rd.STEPS)]
    empty = (0.2 + 0.1j) + 1e-5 * (rng.standard_normal(r.size) + 1j * rng.standard_normal(r.size))
    out = rd.decode(empty, plans.plan("known", 4e6, "viterbi", 1e-3), lo=250, hi=350, n_bits=16, n_reply=n_reply)
    assert not out.found and calls() == [list(rd.STEPS[:3])]

    x, truth = synthetic_capture(exchange_items(2, m=4, with_query=True, duration_s=0.01, blf_hz=256e3),
                                 fs_hz=2e6, trcal_s=64 / 3 / 256e3)
    records, _ = decode_reader_commands(x, 2e6)
    replies = decode_tag_replies(x, 2e6, records)
    assert len(replies) == 2
    assert calls() == [list(rd.STEPS)] * 2


# ----------------------------------------------------------------- one CRC check of decoded replies

#: The CRC-16 routines (:mod:`rfsim.gen2.crc`) whose use is a CRC computation or check.
CRC16_NAMES = {"crc16_ok", "crc16", "crc16_bits", "crc16_bytes", "_crc16_register"}
#: Modules that use them, each with its reason: none checks a reply the decoder decoded (that is
#: the decoder's CRC step, :func:`rfsim.gen2.reply_decoder._crc_check`, and nothing else).
CRC16_USERS = {
    "rfsim/gen2/crc.py": "the home of the CRC routines",
    "rfsim/gen2/reply_decoder.py": "the CRC step of the one reply decoder (only in _crc_check)",
    "rfsim/gen2/commands.py": "reader commands the tag parses (not replies)",
    "rfsim/gen2/capture.py": "reader commands found in a capture (not replies)",
    "rfsim/gen2/memory.py": "the StoredCRC a tag computes over its memory",
    "devices/gen2_tag_state.py": "the tag builds its EPC reply's CRC",
    "rfsim/protocols/inventory.py": "the ideal channel's replies: the tag's bits, nothing decoded",
    "devices/reader_statistic.py": "the statistic receiver (another receiver model, opt-in): its decisions are "
                                   "drawn from statistics, not decoded by the decoder",
    "devices/st_receiver.py": "the sense-a-tag's receiver of a comparator output (not a reader window)",
    "devices/msk_beacon.py": "MSK beacon frames (not Gen2 replies)",
}


def _crc16_uses(tree: ast.AST) -> list[ast.AST]:
    """References to the CRC-16 routines (called or passed on), imports not counted."""
    return [n for n in ast.walk(tree) if (isinstance(n, ast.Name) and n.id in CRC16_NAMES)
            or (isinstance(n, ast.Attribute) and n.attr in CRC16_NAMES)]


def test_decoded_replies_check_their_crc_in_the_decoders_crc_step_only():
    """No module but the allow-listed ones (each with its reason) uses a CRC-16 routine, and the
    decoder uses it in its CRC step only: a second CRC check of decoded replies (the capture
    records' own, the reader's own) fails here. The scan finds the CRC step's use, so it can fail."""
    users = sorted(m for m, tree in MODULES.items() if _crc16_uses(tree))
    assert REPLY_DECODER in users, "the scan does not find the decoder's CRC step"
    assert set(users) <= set(CRC16_USERS), sorted(set(users) - set(CRC16_USERS))
    in_decoder = [name for name, f in _decoder_functions().items() if _crc16_uses(f)]
    assert in_decoder == ["_crc_check"], in_decoder


def test_capture_records_take_their_crc_from_the_crc_step(monkeypatch):
    """A capture record's ``crc_ok`` is the CRC step's result: with the step replaced by one that
    inverts the check, every record with a CRC reports the inverted value (a second check in the
    records would keep the true one), and the RN16 replies ask no CRC (None)."""
    from rfsim.bench.decode import exchange_items, synthetic_capture
    from rfsim.gen2 import reply_decoder as rd
    from rfsim.gen2.capture import decode_reader_commands
    from rfsim.gen2.crc import crc16_ok
    from rfsim.gen2.replies import decode_tag_replies

    x, _ = synthetic_capture(exchange_items(2, m=4, with_query=True, duration_s=0.01, blf_hz=256e3),
                             fs_hz=2e6, trcal_s=64 / 3 / 256e3)
    records, _ = decode_reader_commands(x, 2e6)
    true = decode_tag_replies(x, 2e6, records)
    kinds = [r.kind for r in true]
    assert "RN16" in kinds and "EPC" in kinds
    assert all(r.crc_ok is (None if r.kind == "RN16" else True) for r in true), [(r.kind, r.crc_ok) for r in true]

    def inverted(w, plan):
        if w.crc:
            w.crc_ok = not crc16_ok(w.bits)

    monkeypatch.setitem(rd.VARIANTS["crc"], "check", inverted)  # the capture's plans are made per call
    flipped = decode_tag_replies(x, 2e6, records)
    assert [r.bits for r in flipped] == [r.bits for r in true]
    assert all(r.crc_ok is (None if r.kind == "RN16" else False) for r in flipped), [(r.kind, r.crc_ok) for r in flipped]


# ----------------------------------------------------------------- kernels that compute several steps

#: The function each kernel of ``KERNEL_STEPS`` is reached through from the decoder (its entry).
KERNEL_ENTRIES = {"receive_kernel": "receive_kernel", "receive_batch_kernel": "receive_batch_kernel",
                  "search_decode_kernel": "search_decode",
                  "decode_window_kernel": "_decode_window"}


def _all_plans():
    from itertools import product

    from rfsim.gen2 import reply_decoder as rd
    from rfsim.gen2.reply_search import LinkHypothesis

    plans = [rd.DecodePlan("link", 2e6, hypotheses=(LinkHypothesis(4, False, 2e5, 3e5),), track_timing=True)]
    for search, dc, refit, track in product(("known", "blf"), (True, False), (True, False), (True, False)):
        try:
            plans.append(rd.DecodePlan(search, 4e6, dc_from_lead=dc, refit=refit, track_timing=track))
        except ValueError:
            pass
    return plans


def test_kernel_steps_table_matches_the_plans_and_the_callers():
    """``KERNEL_STEPS``: the variant that calls each kernel calls its entry (and is the only
    variant that does), every variant said to read a kernel's results runs only in plans that
    also run the kernel's caller, and each kernel and variant of the table is named in the module
    docstring's table of kernels. Fails when a step reads a result no step of its plan computed."""
    from rfsim.gen2 import reply_decoder as rd

    funcs = _decoder_functions()
    plans = _all_plans()
    assert len(plans) >= 8
    doc = rd.__doc__.split("Kernels that compute several steps\n")[-1]
    for kernel, ((step, variant), readers) in rd.KERNEL_STEPS.items():
        caller = rd.VARIANTS[step][variant].__name__
        assert KERNEL_ENTRIES[kernel] in _calls(funcs[caller]), (kernel, caller)
        assert [n for n, f in funcs.items() if KERNEL_ENTRIES[kernel] in _calls(f)] == [caller]
        assert f"``{kernel}``" in doc and f'{step} "{variant}"' in doc
        for r_step, r_variant in readers:
            assert r_variant in rd.VARIANTS[r_step], (r_step, r_variant)
            users = [p for p in plans if getattr(p.variants, r_step) == r_variant]
            assert users, (r_step, r_variant)
            assert all(getattr(p.variants, step) == variant for p in users), (kernel, r_step, r_variant)
            assert f'"{r_variant}"' in doc


def test_carrier_phase_referral_is_one_rule():
    """Both receiver models refer the measured phase to the carrier through
    reader_measure.refer_phase; no other module of devices/ computes arg of a carrier with
    cmath.phase (the statistic receiver once did, 1 ULP apart from np.angle in ≈ 7 % of values)."""
    import ast
    from pathlib import Path
    from rfsim.devices import reader_measure, reader_statistic, reader
    assert reader_statistic.refer_phase is reader_measure.refer_phase
    root = Path(reader.__file__).parent
    for path in sorted(root.glob("reader*.py")):
        tree = ast.parse(path.read_text())
        names = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name)
                 and n.value.id == "cmath"}
        assert "phase" not in names, f"{path.name} computes a phase with cmath.phase"
    src = Path(reader.__file__).read_text()
    assert "_refer_phase(" in src
    # the rule: wrap(phase + arg c), arg by np.angle, e.g. c = −1 (arg = π): 0.5 + π
    import math
    assert reader_measure.refer_phase(0.5, -1 + 0j) == math.fmod(0.5 + math.pi, 2 * math.pi)


# ----------------------------------------------------------------- the statistic receiver's piece scale

#: The one definition of the scale √(σ²·|p|/2) of a piece sum's parts in compiled code.
PIECE_SCALE_HOME = ("devices/_reader_statistic_kernels.py", "_piece_scale")
#: Its callers in the kernels: the piece sums and the search block's noise.
PIECE_SCALE_USERS = ("_draw_sums", "_search")
#: Functions allowed a form of their own, each with its reason.
PIECE_SCALE_OTHERS = {
    ("devices/reader_statistic.py", "draw_piece_sums"):
        "the NumPy form over an array of sizes, the twin the tests compare the kernels' draws with",
}


def _piece_scales(tree: ast.AST) -> list[tuple[str, int]]:
    """``(enclosing function, line)`` of every ``sqrt(0.5 * sigma2 …)`` (``math.sqrt``, ``np.sqrt``
    or a bare ``sqrt``, the product starting with 0.5 times a name holding ``sigma2``) in ``tree``."""
    found = []

    def visit(node, where):
        for child in ast.iter_child_nodes(node):
            inner = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else where
            if isinstance(child, ast.Call) and child.args:
                name = child.func.attr if isinstance(child.func, ast.Attribute) else getattr(child.func, "id", "")
                text = ast.unparse(child.args[0]).replace(" ", "")
                if name == "sqrt" and text.startswith("0.5*") and "sigma2" in text:
                    found.append((where, child.lineno))
            visit(child, inner)

    visit(tree, "<module>")
    return found


def test_the_scan_finds_an_inline_piece_scale():
    """The scan finds the inline forms the helper replaced (so the test below can fail)."""
    src = ("def _search(sigma2, b0):\n    one = math.sqrt(0.5 * sigma2 * 1.0)\n"
           "    return one, math.sqrt(0.5 * sigma2 * float(b0 - 1))\n")
    assert [w for w, _ in _piece_scales(ast.parse(src))] == ["_search", "_search"]


def test_the_piece_scale_is_written_once():
    """√(0.5·σ²·|p|) is written in :func:`_piece_scale` only (and the NumPy twin allowed with its
    reason); the piece sums and the search block's noise call it."""
    module, home = PIECE_SCALE_HOME
    where = sorted((m, w) for m, tree in MODULES.items() for w, _ in _piece_scales(tree))
    assert (module, home) in where, "the scan does not find the one definition"
    assert set(where) - {(module, home)} <= set(PIECE_SCALE_OTHERS), where
    assert where.count((module, home)) == 1, where
    for user in PIECE_SCALE_USERS:
        assert home in _calls(_function(module, user)), user


# ----------------------------------------------------------------- the known-level rule

#: The one definition of the samples of known level (preamble or rest state, steady neighbours).
KNOWN_HOME = ("rfsim/gen2/_measure_kernels.py", "known_indices_kernel")
#: Its callers: the sample copy of the reader's receivers and the statistic receiver's indices.
KNOWN_USERS = (("rfsim/gen2/_measure_kernels.py", "known_levels_kernel"),
               ("devices/_reader_statistic_kernels.py", "_known"))


def test_the_known_level_rule_is_written_once():
    """The preamble test of a sample (``_in_preamble``) is read by the one rule only, and the
    receivers reach the rule through it (the statistic receiver's indices without a signal)."""
    module, home = KNOWN_HOME
    readers = sorted((m, f.name) for m, tree in MODULES.items() for f in ast.walk(tree)
                     if isinstance(f, ast.FunctionDef) and f.name != "_in_preamble" and "_in_preamble" in _calls(f))
    assert readers == [KNOWN_HOME], readers
    for user_module, user in KNOWN_USERS:
        assert home in _calls(_function(user_module, user)), user
