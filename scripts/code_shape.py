#!/usr/bin/env python3
"""The shape of linterpd's library code, as docs/DEVELOPMENT.md reports it.

    python3 scripts/code_shape.py            # the figures
    python3 scripts/code_shape.py --long 40  # and every function over 40 code lines

Counts, over src/ without its tests (files named tests.rs or *_tests.rs, and `#[cfg(test)]`
modules): functions over 40 and over 80 code lines (lines that are not blank and not only a
comment, from the `fn` line to its closing brace), `Result<_, String>` in signatures, and the
longest functions. A line-based reading of Rust: braces inside strings and chars are skipped,
which is all the code here needs.
"""

import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent / "src"
FN = re.compile(r"^\s*(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?fn\s+(\w+)")


def strip(line: str) -> str:
    """The line without comments, strings and chars (their braces do not count)."""
    out, i, n = [], 0, len(line)
    while i < n:
        c = line[i]
        if line.startswith("//", i):
            break
        if c == '"':
            j = i + 1
            while j < n and line[j] != '"':
                j += 2 if line[j] == "\\" else 1
            i = j + 1
            out.append('""')
            continue
        if c == "'" and i + 2 < n and (line[i + 2] == "'" or line[i + 1] == "\\"):
            j = line.find("'", i + 2)
            i = (j + 1) if j > 0 else i + 1
            continue
        out.append(c)
        i += 1
    return "".join(out)


def functions(path: pathlib.Path):
    """(name, first line, code lines) of every function outside the file's test modules."""
    lines = path.read_text().splitlines()
    result = []
    depth = 0
    test_depth = None  # depth at which a #[cfg(test)] module opened
    pending_test = False
    stack = []  # (name, start, depth at open, code lines)
    in_raw = False
    for no, raw in enumerate(lines, 1):
        text = raw
        if in_raw:
            if '"#' in text:
                in_raw = False
                text = text[text.index('"#') + 2 :]
            else:
                continue
        if 'r#"' in text and '"#' not in text[text.index('r#"') + 3 :]:
            in_raw = True
            text = text[: text.index('r#"')]
        code = strip(text).strip()
        if code.startswith("#[cfg(test)]"):
            pending_test = True
        m = FN.match(text)
        if m and test_depth is None:
            stack.append([m.group(6), no, depth, 0])
        if stack and code and not code.startswith("#"):
            for f in stack:
                f[3] += 1
        for ch in code:
            if ch == "{":
                if pending_test and test_depth is None:
                    test_depth = depth
                depth += 1
            elif ch == "}":
                depth -= 1
                if test_depth is not None and depth == test_depth:
                    test_depth = None
                if stack and depth == stack[-1][2]:
                    name, start, _, count = stack.pop()
                    result.append((name, start, count))
        if code.endswith(";") and stack and depth == stack[-1][2]:
            stack.pop()  # a declaration without a body
        if code and not code.startswith("#"):
            pending_test = pending_test and "{" not in code and not code.startswith("mod ")
            if code.startswith("mod ") or code.startswith("pub mod "):
                pending_test = False
    return result


def main() -> None:
    long_at = None
    if "--long" in sys.argv:
        long_at = int(sys.argv[sys.argv.index("--long") + 1])
    found = []
    strings = 0
    for path in sorted(ROOT.rglob("*.rs")):
        if path.name == "tests.rs" or path.name.endswith("_tests.rs"):
            continue
        text = path.read_text()
        cut = text.find("#[cfg(test)]\nmod tests")
        strings += len(re.findall(r"Result<[^<>]*(<[^<>]*>)?[^<>]*,\s*String>", text[: cut if cut >= 0 else None]))
        for name, start, count in functions(path):
            found.append((count, f"{path.relative_to(ROOT.parent)}:{start}", name))
    found.sort(reverse=True)
    over40 = [f for f in found if f[0] > 40]
    over60 = [f for f in found if f[0] > 60]
    over80 = [f for f in found if f[0] > 80]
    print(f"functions: {len(found)}; over 40 code lines: {len(over40)}; over 60: {len(over60)}; over 80: {len(over80)}")
    print(f"Result<_, String> in the library: {strings}")
    for count, at, name in found[:10]:
        print(f"  {count:4} {name} ({at})")
    if long_at is not None:
        for count, at, name in found:
            if count > long_at:
                print(f"{count:4} {name} ({at})")


if __name__ == "__main__":
    main()
