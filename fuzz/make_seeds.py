"""Writes the seed corpus into corpus/check/: every examples/* program with
each selector byte (bit 0 dialect: 0 cnc836, 1 heidenhain; bit 1 machine:
0 mill, 1 lathe), and the G-code of docs/dialects.md: its code blocks
(fenced or indented) and its inline G-code snippets such as
`G91 G13 H+1080 Z-3`, each with every selector byte.
Run from fuzz/: python3 make_seeds.py"""
import pathlib
import re

here = pathlib.Path(__file__).resolve().parent
out = here / "corpus" / "check"
out.mkdir(parents=True, exist_ok=True)
n = 0


def write(name, text):
    global n
    for sel in range(4):
        (out / f"{name}_{sel}").write_bytes(bytes([sel]) + text.encode())
        n += 1


for f in sorted((here.parent / "examples").iterdir()):
    write(f"seed_{f.stem}", f.read_text())

# one or more words (letter, optional sign, number), an optional '*' end
INLINE = re.compile(r"^(?:[A-Za-z][+-]?(?:\d+\.?\d*|\.\d+)\s*)+\*?$")
doc = here.parent / "docs" / "dialects.md"
if doc.exists():
    blocks, inline = [], []
    block, fenced, blank = [], False, True
    for line in doc.read_text().splitlines() + [""]:
        if line.startswith("```"):
            if fenced:
                blocks.append("\n".join(block) + "\n")
                block = []
            fenced = not fenced
            continue
        if fenced:
            block.append(line)
        elif line.startswith("    ") and (block or blank):
            # an indented code block (it starts after a blank line)
            block.append(line[4:])
        else:
            if block:
                blocks.append("\n".join(block) + "\n")
                block = []
            for span in re.findall(r"`([^`]+)`", line):
                if INLINE.match(span.strip()) and " " in span.strip():
                    inline.append(span.strip() + "\n")
        blank = not line.strip()
    for i, b in enumerate(blocks):
        write(f"seed_doc_{i}", b)
    for i, s in enumerate(sorted(set(inline))):
        write(f"seed_doc_inline_{i}", s)
print(f"{n} seeds in {out}")
