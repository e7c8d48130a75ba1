#!/usr/bin/python3
"""Rewrites citations of the product spec into citations of the repository's docs/ pages, and
removes tracker numbers from comments.

The product spec that settled what the manual leaves open lived outside the repository; its
sections now have pages in docs/ (docs/development.md "Citations"). This script turns

    emulator-spec §1.1          ->  docs/dp-slave.md "User parameters"
    emulator-spec §2, §6.1      ->  docs/slots.md "Chk_Cfg slots", docs/page-mode.md "Segments"
    emulator-spec §10 "FCB/FCV" ->  docs/profibus.md "FCB/FCV"
    the emulator-spec §10 capture -> the capture in docs/profibus.md "A real master's first ..."
    spec §4      (the short form of docs/decisions.md; never "MB spec", the Modbus specification)

and drops tracker numbers: "(issue 12)", "(docs/faults.md, issue 12)" -> "(docs/faults.md)",
"// Issue 12: idle clients" -> "// Idle clients".

It only touches text a reader reads as prose: comments of C++, JavaScript, Lua, shell and CMake
files, Python comments and docstrings, the ";" comments of GSD files, the values of "_comment"-like
keys of JSON files, and Markdown outside code blocks and code spans. Strings a program prints,
golden outputs (*.txt other than CMakeLists.txt) and other JSON values are never changed: the
script lists what it left, for a person to decide. A paragraph whose line grew past the line limit
(100 characters) is filled again; GSD lines (80) are only reported. Running it a second time
changes nothing.

    tools/cite-docs.py [--check | --headings] [--exclude PATH]... [PATH...]

PATH (default: the whole repository) selects tracked files (git ls-files); --exclude skips a file
or a directory. --check changes nothing and exits 1 when something would change. --headings
changes nothing and lists the citations `docs/PAGE.md "Heading"` whose heading does not exist.
"""

from __future__ import annotations

import argparse
import difflib
import io
import os
import re
import shutil
import subprocess
import sys
import tokenize
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

# ---- where each section of the spec is now ---------------------------------------------------
PAGES: dict[str, tuple[str, str | None]] = {
    "1": ("docs/dp-slave.md", None),
    "1.1": ("docs/dp-slave.md", "User parameters"),
    "2": ("docs/slots.md", "Chk_Cfg slots"),
    "3": ("docs/dp-slave.md", "Diagnosis"),
    "4": ("docs/slots.md", "Data exchange in normal mode"),
    "5": ("docs/communication-window.md", None),
    "6": ("docs/page-mode.md", None),
    "6.1": ("docs/page-mode.md", "Segments"),
    "6.2": ("docs/page-mode.md", "Header bytes"),
    "6.3": ("docs/page-mode.md", "Pages"),
    "7": ("docs/canopen.md", None),
    "8": ("docs/modbus.md", None),
    "9": ("docs/drive-simulator.md", None),
    "10": ("docs/profibus.md", None),
}
# Parts of §10 by the names the spec gave them -> their headings in docs/profibus.md.
SECTION10_PARTS = {
    "Characters": "Characters",
    "Telegrams": "Telegrams",
    "FC of a request/response": "Frame control",
    "DP services over FDL": "DP services over FDL",
    "FCB/FCV": "FCB/FCV",
    "A real master's first telegrams": "A real master's first telegrams",
    "Timing": "Timing",
}
CAPTURE = ("docs/profibus.md", "A real master's first telegrams")

HERE = "\x01"  # stands for "this page" until the citations of a line are complete
LIMIT = 100
GSD_LIMIT = 80
SELF = "tools/cite-docs.py"

NUM = r"(?P<n>\d+(?:\.\d+)?)(?![\d.]\d)"
ITEM = r"§ ?\d+(?:\.\d+)?(?![\d.]\d)"
MORE = rf"(?P<more>(?:(?:, | and | or | / |/)(?:{ITEM}))*)"
MORE_BARE = r"(?P<more>(?: and \d+(?:\.\d+)?(?![\d.]\d))*)"
PART = r'(?:\s+(?:table\s+)?(?P<q>\\?")(?P<part>[^"\\]+)(?P=q))?'
WORD = r"(?P<word>\s+(?:captures?|tables?)\b(?!'s))?"
# "emulator-spec §N" (also "emulator-spec.md §N"), or "spec §N" that is not the Modbus "MB spec".
SPEC = r"(?:emulator-spec(?:\.md)?|(?<![\w-])(?<!MB )spec)"
CITE = re.compile(rf"(?P<the>\b[Tt]he )?{SPEC} ?§ ?{NUM}(?P<poss>'s)?{MORE}{PART}{WORD}")
# GSD comments write "emulator-spec 1.1" and "emulator-spec 1.1 and 2".
CITE_BARE = re.compile(rf"(?P<the>\b[Tt]he )?emulator-spec {NUM}(?P<poss>'s)?{MORE_BARE}")
# A citation broken over two comment lines: "... (emulator-spec" + "// §7) ...".
SPLIT = re.compile(r"emulator-spec\s*$")
SPLIT_NEXT = re.compile(
    r"^(?P<prefix>\s*(?://|#|;|--|\*)?\s*)(?P<sec>§ ?\d+(?:\.\d+)?)(?P<rest>.*)$")

ISSUE = r"[Ii]ssues? #?\d+(?:(?:, | and )#?\d+)*"
ISSUE_RULES = [
    (re.compile(rf"\s*\({ISSUE}\)"), ""),                # "... (issue 12)"
    (re.compile(rf"\({ISSUE}(?:, |; |: |,$|:$)"), "("),   # "(issue 10, emulator-spec §10)"
    (re.compile(rf"(?:, |; ){ISSUE}\)"), ")"),           # "(docs/faults.md, issue 12)"
    (re.compile(rf"(?:, |; ){ISSUE}(?=[,:;])"), ""),     # "(build-deb.sh), issue 11:"
]
ISSUE_LEAD = re.compile(rf"\b(?P<word>{ISSUE}): (?P<next>.)")  # "// Issue 12: idle clients"
ISSUE_ANY = re.compile(rf"\b{ISSUE}\b")
LEFTOVER = re.compile(r"emulator-spec")
DOCS_REF = r'docs/[\w.-]+\.md(?: "[^"]*")?'


@dataclass
class Report:
    changed: list[str] = field(default_factory=list)
    left: list[str] = field(default_factory=list)


# ---- the replacement text --------------------------------------------------------------------
def cite_text(items: Sequence[tuple[str, str | None]], seps: list[str], here: str,
              esc: bool) -> str:
    """The citations of (section, part name) items, merged per page, joined by their separators.
    A page cited on itself becomes "this page" (or "Heading" on this page)."""
    order: list[str] = []
    heads: dict[str, list[str]] = {}
    whole: set[str] = set()
    sep_of: dict[str, str] = {}
    for i, (sec, part) in enumerate(items):
        page, head = PAGES[sec]
        if sec == "10" and part:
            head = SECTION10_PARTS[part]
        if page not in heads:
            order.append(page)
            heads[page] = []
            sep_of[page] = seps[i - 1] if i else ""
        if head is None:
            whole.add(page)
        elif head not in heads[page]:
            heads[page].append(head)
    q = '\\"' if esc else '"'
    out = ""
    for page in order:
        names = ", ".join(f"{q}{h}{q}" for h in ([] if page in whole else heads[page]))
        if page == here:
            text = f"{names} on this page" if names else HERE
        else:
            text = f"{page} {names}".rstrip()
        out += (sep_of[page] if out else "") + text
    return out


def split_more(more: str) -> tuple[list[str], list[str]]:
    secs = [a or b for a, b in re.findall(r"§ ?(\d+(?:\.\d+)?)|\band (\d+(?:\.\d+)?)", more)]
    seps = re.findall(r"(, | and | or | / |/)(?:§|\d)", more)
    return secs, seps


def rewrite_cites(text: str, here: str, esc: bool) -> str:
    q = '\\"' if esc else '"'

    def repl(m: re.Match[str]) -> str:
        first = m.group("n")
        more_secs, seps = split_more(m.group("more") or "")
        if first not in PAGES or any(s not in PAGES for s in more_secs):
            return m.group(0)
        groups = m.groupdict()
        the = groups.get("the") or ""
        part, word = groups.get("part"), groups.get("word")
        if first == "10" and not more_secs and part in SECTION10_PARTS:
            return the + cite_text([("10", part)], [], here, esc) + (word or "")
        if first == "10" and not more_secs and not part and word:
            # "the emulator-spec §10 capture" -> "the capture in docs/profibus.md "...""
            noun = word.strip()
            if noun.startswith("capture"):
                page, head = CAPTURE
                where = (f"{q}{head}{q} on this page" if page == here
                         else f"{page} {q}{head}{q}")
            else:
                where = cite_text([("10", None)], [], here, esc)
            return f"{the[:1] or 't'}he {noun} in {where}" if the else f"the {noun} in {where}"
        cite = cite_text([(first, None)] + [(s, None) for s in more_secs], seps, here, esc)
        rest = m.group(0)[m.end("more") - m.start():]  # a quotation after it, kept
        after = m.string[m.end():]
        if rest.strip().startswith(("\"", "\\\"")) or (not rest and after.startswith(' "')):
            rest = ":" + rest
        if m.group("poss"):
            rest = "'s" + rest  # "emulator-spec §10's tables" -> "docs/profibus.md's tables"
            cite = "this page" if cite == HERE else cite
        return the + cite + rest

    out = CITE_BARE.sub(repl, CITE.sub(repl, text))
    # "docs/profibus.md, docs/profibus.md "Performance"" -> the second alone; likewise a Markdown
    # link to the same page.
    out = re.sub(r'docs/([\w.-]+)\.md, (docs/\1\.md(?: "[^"]*")?|\[\1\.md\]\(\1\.md[^)]*\))',
                 r"\2", out)
    out = re.sub(r'(\[([\w.-]+)\.md\]\(\2\.md[^)]*\)), docs/\2\.md(?! ")', r"\1", out)
    # A citation of the page it stands on adds nothing: "(this page)", ", this page".
    out = re.sub(rf" ?\({HERE}\)|, {HERE}|{HERE}, ", "", out)
    return out.replace(HERE, "this page")


def rewrite_issues(text: str) -> str:
    for rx, rep in ISSUE_RULES:
        text = rx.sub(rep, text)

    def lead(m: re.Match[str]) -> str:
        # Capitalize where the removed words started a sentence or a comment.
        starts = re.fullmatch(r"[\s/#;*\"'-]*", text[:m.start()]) is not None
        nxt = m.group("next")
        return nxt.upper() if starts or m.group("word")[0] == "I" else nxt

    return ISSUE_LEAD.sub(lead, text)


def rewrite(text: str, here: str, esc: bool, issues: bool) -> str:
    out = rewrite_cites(text, here, esc)
    return rewrite_issues(out) if issues else out


# ---- which parts of a line are prose ---------------------------------------------------------
Span = tuple[int, int]


def spans_c(lines: list[str], lua: bool = False) -> list[list[Span]]:
    """Comment spans of C, C++, JavaScript (or Lua) source, per line."""
    result: list[list[Span]] = []
    block = False
    raw_end: str | None = None
    for line in lines:
        spans: list[Span] = []
        i, n, start = 0, len(line), 0
        while i < n:
            if raw_end is not None:  # inside a C++ raw string
                j = line.find(raw_end, i)
                if j < 0:
                    break
                i, raw_end = j + len(raw_end), None
                continue
            if block:
                j = line.find("]]" if lua else "*/", i)
                if j < 0:
                    spans.append((start, n))
                    break
                spans.append((start, j))
                block, i = False, j + 2
                continue
            if lua and line.startswith("--[[", i) or not lua and line.startswith("/*", i):
                block = True
                i = start = i + (4 if lua else 2)
                continue
            if line.startswith("--" if lua else "//", i):
                spans.append((i, n))
                break
            c = line[i]
            if not lua and line.startswith('R"', i) and (i == 0 or not line[i - 1].isalnum()):
                j = line.find("(", i + 2)
                if j > 0:
                    raw_end = ")" + line[i + 2:j] + '"'
                    i = j + 1
                    continue
            if c in "\"'`" and not (c == "'" and i and line[i - 1].isalnum()):
                j = i + 1
                while j < n and line[j] != c:
                    j += 2 if line[j] == "\\" else 1
                i = j + 1
                continue
            i += 1
        result.append(spans)
    return result


def spans_marker(lines: list[str], marker: str) -> list[list[Span]]:
    """The rest of each line after a comment marker outside quotes (shell, CMake: '#'; GSD: ';')."""
    result = []
    for line in lines:
        quote = None
        spans: list[Span] = []
        for i, c in enumerate(line):
            if quote:
                if c == quote:
                    quote = None
            elif c == '"' or (c == "'" and marker == "#" and (i == 0 or not line[i - 1].isalnum())):
                quote = c
            elif c == marker and (marker == ";" or i == 0 or line[i - 1] in " \t("):
                spans.append((i, len(line)))
                break
        result.append(spans)
    return result


def spans_python(text: str, lines: list[str]) -> list[list[Span]]:
    """Comments and triple-quoted strings (docstrings) of Python source."""
    result: list[list[Span]] = [[] for _ in lines]
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(text).readline))
    except (tokenize.TokenError, SyntaxError):
        return result
    for tok in tokens:
        if tok.type == tokenize.COMMENT:
            result[tok.start[0] - 1].append((tok.start[1], tok.end[1]))
        elif tok.type == tokenize.STRING and re.match(r"^[rRbBuUfF]*(\"\"\"|''')", tok.string):
            (r0, c0), (r1, c1) = tok.start, tok.end
            for r in range(r0, r1 + 1):
                result[r - 1].append((c0 if r == r0 else 0, c1 if r == r1 else len(lines[r - 1])))
    return result


def spans_markdown(lines: list[str]) -> list[list[Span]]:
    """Markdown outside fenced code blocks and `code spans`."""
    result: list[list[Span]] = []
    fence = False
    for line in lines:
        if line.lstrip().startswith("```"):
            fence = not fence
            result.append([])
            continue
        if fence:
            result.append([])
            continue
        spans: list[Span] = []
        pos = 0
        for m in re.finditer(r"`[^`]*`", line):
            spans.append((pos, m.start()))
            pos = m.end()
        spans.append((pos, len(line)))
        result.append(spans)
    return result


JSON_COMMENT = re.compile(r'"_[A-Za-z0-9_]*"\s*:\s*"((?:[^"\\]|\\.)*)"')


def spans_json(lines: list[str]) -> list[list[Span]]:
    """The values of keys that start with '_' (comments the reader ignores)."""
    return [[(m.start(1), m.end(1)) for m in JSON_COMMENT.finditer(line)] for line in lines]


def kind_of(path: str) -> str | None:
    name = path.rsplit("/", 1)[-1]
    ext = name.rsplit(".", 1)[-1].lower() if "." in name else ""
    if name == "CMakeLists.txt" or ext == "cmake":
        return "hash"
    if ext in ("cpp", "hpp", "h", "c", "cc", "js"):
        return "c"
    if ext in ("lua", "md", "json", "gsd"):
        return ext
    shebang = first_line(path) if not ext else ""
    if ext == "py" or "python" in shebang:
        return "python"
    if ext in ("sh", "bash") or re.search(r"\b(ba)?sh\b", shebang):
        return "hash"
    return None


def first_line(path: str) -> str:
    """The "#!" line of a script without an extension, else ""."""
    try:
        with open(path, encoding="utf-8") as f:
            line = f.readline()
    except (OSError, UnicodeDecodeError):
        return ""
    return line if line.startswith("#!") else ""


# ---- filling a paragraph that grew past the limit --------------------------------------------
LIST_ITEM = re.compile(r"(?:[-*•]|\d+\.|\|) ")


def prose_prefix(line: str, span_start: int, kind: str) -> tuple[str, str] | None:
    """(what stays in front of the text on the first line, the prefix of continuation lines)."""
    if kind == "md":
        if line.lstrip().startswith(("|", "#", ">")):
            return None  # table rows, headings and quotes stay one line
        indent = line[:len(line) - len(line.lstrip(" \t"))]
        item = LIST_ITEM.match(line[len(indent):])
        if item:
            return indent + item.group(0), indent + " " * len(item.group(0))
        return indent, indent
    m = re.match(r"(//+|#+|;+|--)[ \t]?", line[span_start:])
    if m:
        before = line[:span_start]
        lead = before if before.strip() == "" else " " * len(before)
        return line[:span_start] + m.group(0), lead + m.group(0)
    if kind == "python":  # a docstring line
        indent = line[:len(line) - len(line.lstrip(" \t"))]
        return indent, indent
    return None  # inside a block comment: left as it is


def continues(line: str, prefix: str, kind: str) -> bool:
    """True when `line` continues the paragraph whose continuation lines start with `prefix`."""
    if not line.startswith(prefix) or len(line) == len(prefix):
        return False
    text = line[len(prefix):]
    if text[0] in " \t" or LIST_ITEM.match(text) or '"""' in line or "'''" in line:
        return False
    if kind == "md":
        return not re.match(r"[ \t]*(?:[-*]|\d+\.|```|#|\||>)", line)
    return prefix.strip() != "" and line[:len(prefix)].strip() == prefix.strip()


def fill(first: str, text: str, prefix: str, limit: int) -> list[str]:
    """Greedy fill. A docs citation with its heading is kept on one line, unless it does not fit
    behind the code a trailing comment stands after."""
    words = re.findall(rf'[^\s"]*{DOCS_REF}\S*|\S+', text)
    lines, cur = [], first
    while words:
        w = words.pop(0)
        sep = "" if cur in (first, prefix) else " "
        if len(cur) + len(sep) + len(w) > limit:
            if cur not in (first, prefix):
                lines.append(cur)
                cur, sep = prefix, ""
            elif cur == first and " " in w:
                words[:0] = w.split(" ")
                continue
        cur += sep + w
    lines.append(cur)
    return lines


def rule_line(line: str, old: str, limit: int) -> str:
    """A heading rule ("// ---- title ------") keeps its old length through its trailing dashes."""
    m, o = re.search(r" (-{3,})$", line), re.search(r" -{3,}$", old)
    if not m or not o:
        return line
    dashes = max(3, len(old) - (len(line) - len(m.group(1))))
    return line[:m.start(1)] + "-" * min(dashes, max(3, limit - m.start(1)))


def reflow(lines: list[str], changed: list[bool], spans: list[list[Span]], kind: str,
           limit: int) -> list[str]:
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        pre = None
        if changed[i] and len(line) > limit and kind not in ("json", "gsd"):
            pre = prose_prefix(line, min((a for a, _ in spans[i]), default=0), kind)
        if pre is None:
            out.append(line)
            i += 1
            continue
        first, cont = pre
        texts = [line[len(first):]]
        j = i + 1
        while j < len(lines) and continues(lines[j], cont, kind):
            texts.append(lines[j][len(cont):])
            j += 1
        text = " ".join(t.strip() for t in texts)
        if kind == "python" and not first.lstrip().startswith("#") and "#" in first:
            # A trailing comment too long for its line goes above the statement (flake8 wants
            # comment lines at the statement's indentation).
            code_part = first[:first.rindex("#")].rstrip()
            indent = code_part[:len(code_part) - len(code_part.lstrip())]
            out.extend(fill(indent + "# ", text, indent + "# ", limit))
            out.append(code_part)
        else:
            out.extend(fill(first, text, cont, limit))
        i = j
    return out


# ---- one file --------------------------------------------------------------------------------
def join_split_citations(lines: list[str]) -> list[str]:
    """ "... (emulator-spec" + "// §7) ..." -> "... (emulator-spec §7)" + "// ..." (or nothing:
    the continuation line disappears when nothing but punctuation followed the section)."""
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        m = SPLIT_NEXT.match(lines[i + 1]) if SPLIT.search(line) and i + 1 < len(lines) else None
        if m:
            rest = m.group("rest")
            moved = rest[:len(rest) - len(rest.lstrip(").,:;"))]
            remaining = rest[len(moved):].lstrip()
            out.append(line.rstrip() + " " + m.group("sec") + moved)
            if remaining:
                out.append(m.group("prefix") + remaining)
            i += 2
            continue
        out.append(line)
        i += 1
    return out


def spans_of(kind: str, text: str, lines: list[str]) -> list[list[Span]]:
    if kind == "c":
        return spans_c(lines)
    if kind == "lua":
        return spans_c(lines, lua=True)
    if kind == "python":
        return spans_python(text, lines)
    if kind == "hash":
        return spans_marker(lines, "#")
    if kind == "gsd":
        return spans_marker(lines, ";")
    if kind == "md":
        return spans_markdown(lines)
    return spans_json(lines)


def process(path: str, check: bool, report: Report) -> None:
    kind = kind_of(path)
    if kind is None or path == SELF:
        return
    try:
        original = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return
    if not re.search(r"emulator-spec|(?<!MB )spec §|\b[Ii]ssues? #?\d", original):
        return
    here = path if path.startswith("docs/") else ""
    lines = original.split("\n")
    if kind != "json":
        lines = join_split_citations(lines)
    spans = spans_of(kind, "\n".join(lines), lines)
    limit = GSD_LIMIT if kind == "gsd" else LIMIT
    history = False
    new_lines: list[str] = []
    new_spans: list[list[Span]] = []
    changed: list[bool] = []
    for no, (line, sp) in enumerate(zip(lines, spans), start=1):
        if kind == "md" and line.startswith("#"):
            history = bool(re.search(r"history|changelog|release notes", line, re.I))
        new = line
        for a, b in sorted(sp, reverse=True):
            new = new[:a] + rewrite(new[a:b], here, kind == "json", not history) + new[b:]
        if new != line:
            new = rule_line(new, line, limit)
        # A citation removed at the start of a line leaves its punctuation: to the line before;
        # a comment line left with nothing else goes.
        lead = re.match(r"[ \t]*(?://|#|;|--)?[ \t]*", new) if new != line else None
        punct = re.match(r"([.,;:)]+)(?=\s|$)", new[lead.end():]) if lead else None
        if lead and punct and new_lines and new_lines[-1].strip() and \
                not re.match(r"[ \t]*(?://|#|;|--)?[ \t]*[.,;:)]", line):
            new_lines[-1] += punct.group(1)
            changed[-1] = True
            rest = new[lead.end() + punct.end():].strip()
            if not rest:
                continue
            new = new[:lead.end()] + rest
        new_lines.append(new)
        new_spans.append(sp)
        changed.append(new != line)
        prose = [new[a:b] for a, b in spans_of(kind, new, [new])[0]] if kind != "python" else \
            [new]
        if LEFTOVER.search(new) or (not history and any(ISSUE_ANY.search(p) for p in prose)):
            report.left.append(f"{path}:{no}: {new.strip()[:110]}")
        if kind == "gsd" and len(new) > limit >= len(line):
            report.left.append(f"{path}:{no}: longer than {limit} characters now")
    result = "\n".join(reflow(new_lines, changed, new_spans, kind, limit))
    if result != original:
        report.changed.append(path)
        if not check:
            Path(path).write_text(result, encoding="utf-8")
            if kind == "c" and not path.endswith(".js"):
                clang_format(path, original, result)


def clang_format(path: str, before: str, after: str) -> None:
    """clang-format (the repository's .clang-format) on the lines this script changed: a trailing
    comment that grew may make it lay out the statement differently."""
    tool = shutil.which("clang-format")
    if tool is None:
        print(f"note: no clang-format: run it on the changed lines of {path}", file=sys.stderr)
        return
    ranges = []
    matcher = difflib.SequenceMatcher(a=before.split("\n"), b=after.split("\n"), autojunk=False)
    for op, _, _, b0, b1 in matcher.get_opcodes():
        if op != "equal" and b1 > b0:
            ranges.append(f"--lines={b0 + 1}:{b1}")
    if ranges:
        subprocess.run([tool, "-i", *ranges, path], check=True)


def tracked(paths: list[str], excludes: list[str]) -> list[str]:
    files = subprocess.run(["git", "ls-files", "-z", "--", *paths], check=True,
                           capture_output=True).stdout.decode().split("\0")
    ex = [e.rstrip("/") for e in excludes]
    return [f for f in files if f and not any(f == e or f.startswith(e + "/") for e in ex)]


def missing_headings(files: list[str]) -> list[str]:
    """Citations `docs/PAGE.md "Heading"` whose page or heading does not exist (a heading may be
    cited by its beginning; backticks in headings are ignored; a paragraph's bold label, as in
    "- **Initial transmission in layer-2 mode.** ...", counts as a heading)."""
    heads: dict[str, list[str]] = {}
    for f in files:
        if f.startswith("docs/") and f.endswith(".md"):
            text = Path(f).read_text(encoding="utf-8")
            heads[f] = [ln.lstrip("#").strip().replace("`", "") for ln in text.split("\n")
                        if ln.startswith("#")]
            heads[f] += [m.group(1).replace("`", "")
                         for m in re.finditer(r"^(?:- )?\*\*([^*]+?)\.?\*\*", text, re.M)]
    found = []
    for f in files:
        if f == SELF or kind_of(f) is None:
            continue
        try:
            text = Path(f).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            continue
        for m in re.finditer(r'docs/([\w.-]+\.md) \\?"([^"\\]+)\\?"', text):
            page, head = "docs/" + m.group(1), " ".join(m.group(2).split())
            head = re.sub(r"\s*(//|#|;)\s*", " ", head) if "\n" in m.group(2) else head
            if not any(h.startswith(head) for h in heads.get(page, [])):
                line = text.count("\n", 0, m.start()) + 1
                found.append(f'{f}:{line}: {page} "{head}"')
    return found


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("paths", nargs="*", default=["."], help="files or directories (tracked files)")
    ap.add_argument("--exclude", action="append", default=[], metavar="PATH",
                    help="a file or directory to leave alone (repeatable)")
    ap.add_argument("--check", action="store_true",
                    help="change nothing; exit 1 if something would change")
    ap.add_argument("--headings", action="store_true",
                    help="only list docs/ citations whose page or heading does not exist")
    args = ap.parse_args()
    root = Path(subprocess.run(["git", "rev-parse", "--show-toplevel"], check=True,
                               capture_output=True, text=True).stdout.strip())

    def rel(p: str) -> str:
        return os.path.relpath(Path(p).resolve(), root)

    paths = [rel(p) for p in args.paths]
    excludes = [rel(p) for p in args.exclude]
    os.chdir(root)
    if args.headings:
        missing = missing_headings(tracked(paths, excludes))
        for line in missing:
            print(line)
        return 1 if missing else 0
    report = Report()
    for f in tracked(paths, excludes):
        process(f, args.check, report)
    for f in report.changed:
        print(("would change " if args.check else "changed ") + f)
    if report.left:
        print("left for a person (strings a program prints, unusual forms, long GSD lines):",
              file=sys.stderr)
        for line in report.left:
            print("  " + line, file=sys.stderr)
    return 1 if args.check and report.changed else 0


if __name__ == "__main__":
    sys.exit(main())
