"""Writes the seed corpus into corpus/check/: every examples/* program with
each selector byte (bit 0 dialect: 0 cnc836, 1 heidenhain; bit 1 machine:
0 mill, 1 lathe), and the indented code blocks of the spec's dialects.md
(when ../../shared/spec exists). Run from fuzz/: python3 make_seeds.py"""
import os
import pathlib

here = pathlib.Path(__file__).resolve().parent
out = here / "corpus" / "check"
out.mkdir(parents=True, exist_ok=True)
n = 0
for f in sorted((here.parent / "examples").iterdir()):
    text = f.read_bytes()
    for sel in range(4):
        (out / f"seed_{f.stem}_{sel}").write_bytes(bytes([sel]) + text)
        n += 1
spec = here.parent.parent / "shared" / "spec" / "dialects.md"
if spec.exists():
    block, blocks = [], []
    for line in spec.read_text().splitlines() + [""]:
        if line.startswith("    "):
            block.append(line[4:])
        elif block:
            blocks.append("\n".join(block) + "\n")
            block = []
    for i, b in enumerate(blocks):
        for sel in range(4):
            (out / f"seed_spec_{i}_{sel}").write_bytes(bytes([sel]) + b.encode())
            n += 1
print(f"{n} seeds in {out}")
