"""Issue 18: no module outside ``physics/`` names a particular term or its groups.

The terms carry everything about themselves; a module elsewhere that writes ``scene.h_r`` or
``"tip_moment"`` must be edited whenever a term is added or changed. While the package moved there,
STILL_NAMING_TERMS listed the modules that still did, with how many times (a ratchet that only
shrank); it is now empty, and a module that starts naming a term fails the test.
Docstrings and comments do not count; names, attributes, arguments, definitions and string values
(help texts and f-strings included) do, also inside a longer name or text (``field_mT_of_h_r``,
``"tip_force_N"``, ``"--h-r"`` does not: a flag is spelled by the term itself).

Two kinds of module are outside the rule, each for a stated reason (INDEPENDENT, NOT_THE_ROD'S):
the independent references, which are written from THEORY.md by hand on purpose (a reference that
asked the terms would check the code against itself), and a field source's own properties that
share a word with a rod's term (a permanent magnet's remanence and magnetisation).
"""
import ast
import re
from collections import Counter
from pathlib import Path

from actuator_design.physics.registry import registered_terms

PACKAGE = Path(__file__).resolve().parents[1] / "actuator_design"

#: words naming a term's groups that are not a registered term's or parameter's name
GROUP_WORDS = {"magnetization", "magnetisation", "remanence", "chi_bar", "chi_hat", "saturation"}


def term_words() -> set:
    """Every registered term's name (bending is every rod's, so not a particular term), every
    parameter name of a term that is not a generic lens symbol (those with an underscore), and the
    group words of GROUP_WORDS."""
    terms = registered_terms()
    words = {c.name for c in terms} - {"bending"}
    words |= {p.name for c in terms for p in c.parameters if "_" in p.name}
    return words | GROUP_WORDS


def _docstring_nodes(tree) -> set:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
                    and isinstance(first.value.value, str):
                out.add(id(first.value))
    return out


def term_mentions(source: str, words: set) -> Counter:
    """How often ``source`` names each of ``words`` in code (not in docstrings or comments): as a
    whole name or text, or as a part of one bounded by anything but a letter or digit."""
    tree = ast.parse(source)
    docstrings = _docstring_nodes(tree)
    patterns = {w: re.compile(rf"(?<![A-Za-z0-9]){re.escape(w)}(?![A-Za-z0-9])") for w in words}
    found = Counter()
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            text = node.attr
        elif isinstance(node, ast.Name):
            text = node.id
        elif isinstance(node, (ast.keyword, ast.arg)):
            text = node.arg
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            text = node.name
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
            text = node.value
        else:
            continue
        for word, pattern in patterns.items():
            found[word] += len(pattern.findall(text or ""))
    return +found


#: Rooms of independent references, outside the rule: closed forms and shooting written from
#: THEORY.md (reference/), and the ``bench`` command's peer (scipy's solve_bvp on the same ODE) with
#: the adapters that hand a scene to these references (benchmarks/). A new term is checked by a
#: reference written for it, never by one derived from the term itself.
INDEPENDENT = ("reference", "benchmarks")

#: Words a module uses for a field source's own property, not a rod's term: a permanent magnet's
#: magnetisation M (A/m, magpylib's ``magnetization=``) and remanence B_r (T), its tolerance axis
#: included. module -> the words it may use so.
NOT_THE_RODS = {
    "model/sources.py": {"magnetization"},
    "config/source_specs.py": {"remanence"},
    "hardware/pose_design.py": {"remanence"},
    "cli/design/pose.py": {"remanence"},
}


def mentions_outside_physics() -> dict:
    words = term_words()
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        if rel.parts[0] == "physics" or rel.parts[0] in INDEPENDENT:
            continue
        found = term_mentions(path.read_text(encoding="utf-8"), words)
        n = sum(v for w, v in found.items() if w not in NOT_THE_RODS.get(rel.as_posix(), ()))
        if n:
            out[rel.as_posix()] = n
    return out


#: module -> how many times it still names a term (the ratchet; see the module docstring)
STILL_NAMING_TERMS: dict = {}


def test_no_module_outside_physics_starts_naming_terms_and_the_list_only_shrinks():
    now = mentions_outside_physics()
    new = sorted(f"{m}: {n}" for m, n in now.items() if m not in STILL_NAMING_TERMS)
    more = sorted(f"{m}: {now[m]} > {STILL_NAMING_TERMS[m]}" for m in now
                  if m in STILL_NAMING_TERMS and now[m] > STILL_NAMING_TERMS[m])
    assert not new and not more, ("modules outside physics/ naming a term (ask the term instead: "
                                  "physics/terms.py):\n" + "\n".join(new + more))
    fewer = sorted(f"{m}: {now.get(m, 0)} (listed {n})" for m, n in STILL_NAMING_TERMS.items() if now.get(m, 0) < n)
    assert not fewer, "lower these counts in STILL_NAMING_TERMS (or drop the module):\n" + "\n".join(fewer)


def test_the_scan_counts_code_and_not_docstrings_or_comments():
    source = ('"""Names h_r."""\n'
              "def f(scene, tip_force=None):  # h_r\n"
              '    """h_r"""\n'
              '    return scene.h_r, {"tip_moment": 1}, g(h_pos=2), f"h_r and {x} more", "--h-r", "h_rate"\n'
              "def field_of_h_r(tip_force_N): pass\n")
    assert term_mentions(source, {"h_r", "tip_force", "tip_moment", "h_pos"}) == Counter(
        {"h_r": 3, "tip_force": 2, "tip_moment": 1, "h_pos": 1})


def test_the_words_cover_every_registered_term_and_its_named_parameters():
    words = term_words()
    assert {"hard_magnetic", "h_r", "magnetization", "tip_moment", "m_tip", "foundation", "k_foundation"} <= words
    assert not {"h", "phi", "alpha", "bending"} & words  # generic lens symbols and every rod's bending


def test_the_exemptions_are_what_they_say():
    """The independent rooms import none of the terms (physics/): their energies and equations are
    their own, not the code they check (the bench runs that code, it does not borrow from it); and a
    word a module may use for a field source's property is one it uses."""
    import ast
    for room in INDEPENDENT:
        for path in (PACKAGE / room).glob("*.py"):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            imported = [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
            imported += [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
            assert not [m for m in imported if m.startswith("actuator_design.physics")], path
    words = term_words()
    for module, allowed in NOT_THE_RODS.items():
        found = term_mentions((PACKAGE / module).read_text(encoding="utf-8"), words)
        assert allowed <= set(found), module
