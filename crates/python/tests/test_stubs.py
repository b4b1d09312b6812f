"""The type stubs (haptic6d.pyi) describe the module as it is: every public name, class
member and keyword is in both."""

import ast
import inspect
import pathlib

import haptic6d

STUB = pathlib.Path(__file__).resolve().parents[1] / "haptic6d.pyi"


def stub_tree() -> ast.Module:
    return ast.parse(STUB.read_text())


def top_level_names(tree: ast.Module) -> set:
    names = set()
    for node in tree.body:
        if isinstance(node, (ast.ClassDef, ast.FunctionDef)):
            names.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
    return names


def stub_class(tree: ast.Module, name: str) -> ast.ClassDef:
    return next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == name)


def members(cls: ast.ClassDef) -> set:
    out = set()
    for n in cls.body:
        if isinstance(n, ast.FunctionDef):
            out.add(n.name)
        elif isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name):
            out.add(n.target.id)
    return out


def test_every_public_name_is_in_the_stubs_and_back():
    names = top_level_names(stub_tree())
    assert set(haptic6d.__all__) == names


def test_class_members_match():
    tree = stub_tree()
    for name in ("Engine", "Tree", "FrameInfo"):
        cls = getattr(haptic6d, name)
        public = {m for m in dir(cls) if not m.startswith("_")}
        assert members(stub_class(tree, name)) == public, name


def test_setting_keywords_match_the_engine():
    # Every keyword the stubs list is accepted (None keeps the scene's value) ...
    tree = stub_tree()
    engine = stub_class(tree, "Engine")
    from_scene = next(n for n in engine.body if isinstance(n, ast.FunctionDef) and n.name == "from_scene")
    keywords = [a.arg for a in from_scene.args.kwonlyargs]
    haptic6d.Engine.from_scene("bunny", **{k: None for k in keywords})
    # ... and each is a setting the engine reports.
    assert set(keywords) == set(haptic6d.Engine.from_scene("bunny").settings())
    # The tree functions' keywords are the module's.
    for fn in ("build_tree", "eval_tree"):
        node = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == fn)
        sig = inspect.signature(getattr(haptic6d, fn))
        assert [a.arg for a in node.args.args + node.args.kwonlyargs] == list(sig.parameters), fn
