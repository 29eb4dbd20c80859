"""The size rules of the package (issue 33, "sizes that fit in a head"): no source file over 600
lines, no function over 100 lines of code, no public function with more than 12 parameters.

Measured with :mod:`ast` and :mod:`tokenize` over ``src/femupdate``:

* a file's lines are its physical lines;
* a function's lines of code are the lines of its definition (decorators and nested functions
  included) that hold a token, less the lines of docstrings, blank lines and comments;
* a function is public when neither it (``__init__`` aside), nor a class around it, nor a
  module or package on its path begins with an underscore, and it is not nested in a function;
  its parameters are the named ones, less ``self`` / ``cls`` (``*args`` and ``**kwargs`` are not
  counted: option shorthand goes there).
"""

from __future__ import annotations

import ast
import functools
import io
import tokenize
from dataclasses import dataclass
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "femupdate"

MAX_FILE_LINES = 600
MAX_FUNCTION_CODE_LINES = 100
MAX_PUBLIC_PARAMETERS = 12


@dataclass(frozen=True)
class Function:
    where: str  # "path:line"
    name: str  # qualified within its module
    code_lines: int
    parameters: int
    public: bool


def _docstring_lines(tree: ast.AST) -> set[int]:
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                    and isinstance(body[0].value.value, str):
                out.update(range(body[0].lineno, body[0].end_lineno + 1))
    return out


def _code_lines(source: str, tree: ast.AST) -> set[int]:
    """The lines that hold a token other than a comment, less the docstrings' lines."""
    skip = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER}
    lines: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type not in skip:
            lines.update(range(tok.start[0], tok.end[0] + 1))
    return lines - _docstring_lines(tree)


def functions(source: str, where: str, public_module: bool = True) -> list[Function]:
    """Every function of ``source`` (nested ones too) with its measures."""
    tree = ast.parse(source)
    code = sorted(_code_lines(source, tree))
    out: list[Function] = []

    def visit(node: ast.AST, prefix: str, public: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                start = min([d.lineno for d in child.decorator_list] + [child.lineno])
                n_code = sum(1 for ln in code if start <= ln <= child.end_lineno)
                a = child.args
                named = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs) if x.arg not in ("self", "cls")]
                is_public = public and (not child.name.startswith("_") or child.name == "__init__")
                out.append(Function(f"{where}:{child.lineno}", prefix + child.name, n_code, len(named), is_public))
                visit(child, prefix + child.name + ".", False)
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".", public and not child.name.startswith("_"))
            else:
                visit(child, prefix, public)

    visit(tree, "", public_module)
    return out


@functools.cache
def _measured() -> tuple[tuple[tuple[str, int], ...], tuple[Function, ...]]:
    """Each source file's (path, lines), and every function's measures, read once."""
    files, funcs = [], []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent)
        public = not any(part.startswith("_") and part != "__init__.py" for part in rel.parts)
        src = path.read_text(encoding="utf-8")
        files.append((rel.as_posix(), len(src.splitlines())))
        funcs += functions(src, rel.as_posix(), public)
    return tuple(files), tuple(funcs)


def test_the_measures_count_what_they_say():
    """The measures on a known source: they can find an offender."""
    src = '''
def f(a, b, c, d, e, f, g, h, i, j, k, l, m, *args, **kwargs):
    """Doc.

    More doc.
    """
    # a comment

    x = (1,
         2)
    return x


class C:
    def __init__(self, a, b):
        def inner(z):
            return z
        self.a = a

    def _private(self, a, b, c, d, e, f, g, h, i, j, k, l, m):
        pass


class _Hidden:
    def method(self, a, b, c, d, e, f, g, h, i, j, k, l, m):
        pass
'''
    got = {fn.name: fn for fn in functions(src, "x.py")}
    assert (got["f"].code_lines, got["f"].parameters, got["f"].public) == (4, 13, True)  # def, x = (1, 2), return
    assert (got["C.__init__"].code_lines, got["C.__init__"].parameters, got["C.__init__"].public) == (4, 2, True)
    assert (got["C.__init__.inner"].code_lines, got["C.__init__.inner"].public) == (2, False)
    assert not got["C._private"].public and not got["_Hidden.method"].public
    assert all(not fn.public for fn in functions(src, "x.py", public_module=False))


def test_no_source_file_is_over_600_lines():
    long = [f"{rel} ({n} lines)" for rel, n in _measured()[0] if n > MAX_FILE_LINES]
    assert not long, f"source files over {MAX_FILE_LINES} lines: " + "; ".join(long)


def test_no_function_is_over_100_lines_of_code():
    long = [f"{fn.name} at {fn.where} ({fn.code_lines} lines of code)"
            for fn in _measured()[1] if fn.code_lines > MAX_FUNCTION_CODE_LINES]
    assert not long, f"functions over {MAX_FUNCTION_CODE_LINES} lines of code: " + "; ".join(long)


def test_no_public_function_has_more_than_12_parameters():
    many = [f"{fn.name} at {fn.where} ({fn.parameters} parameters)"
            for fn in _measured()[1] if fn.public and fn.parameters > MAX_PUBLIC_PARAMETERS]
    assert not many, (f"public functions with more than {MAX_PUBLIC_PARAMETERS} parameters (take an option object "
                      f"instead): " + "; ".join(many))


def test_an_offender_is_named(monkeypatch):
    """With the limits at 0 everything offends: the messages name the files and functions."""
    monkeypatch.setitem(globals(), "MAX_FILE_LINES", 0)
    monkeypatch.setitem(globals(), "MAX_FUNCTION_CODE_LINES", 0)
    monkeypatch.setitem(globals(), "MAX_PUBLIC_PARAMETERS", 0)
    with pytest.raises(AssertionError, match=r"femupdate/generators\.py \(\d+ lines\)"):
        test_no_source_file_is_over_600_lines()
    with pytest.raises(AssertionError, match=r"frame_lattice at femupdate/generators\.py:\d+ \(\d+ lines of code\)"):
        test_no_function_is_over_100_lines_of_code()
    with pytest.raises(AssertionError, match=r"frame_lattice at femupdate/generators\.py:\d+ \(10 parameters\)"):
        test_no_public_function_has_more_than_12_parameters()
