#!/usr/bin/env python3
"""The engines' AVX2 kernels, as linked into a binary, are vectorized.

An engine template is compiled in every object that uses it and the linker keeps one copy: an object compiled at
a lower optimisation level than the build's (for build time) gave the CLI and the Python module scalar copies of
C-RK4's finishing kernels, which their spectral runs then used (session 50). This reads the binary's machine code
(objdump) and fails if any engine kernel compiled for AVX2 (a name ending in _avx2) over a state of run-time size
(std::vector) holds no 256-bit instruction.

usage: vectorized_kernels.py BINARY...   (exit 0: every such kernel vectorized; 1: not; 77: objdump missing)
"""
import re, shutil, subprocess, sys

HEAD = re.compile(r"^[0-9a-f]+ <(.*)>:$")
KERNEL = re.compile(r"^eci::.*std::vector<.*::\w+_avx2\(")


def kernels(binary):
    """{name: (instructions, vector instructions)} of the engine kernels in binary."""
    out = subprocess.run(["objdump", "-d", "-C", "--no-show-raw-insn", binary], check=True, capture_output=True,
                         text=True).stdout
    found, name = {}, None
    for line in out.splitlines():
        m = HEAD.match(line)
        if m:
            name = m.group(1) if KERNEL.match(m.group(1)) else None
            if name:
                found.setdefault(name, [0, 0])
            continue
        if name and line.startswith("  "):
            found[name][0] += 1
            if "%ymm" in line or "%zmm" in line:
                found[name][1] += 1
    return found


def main(argv):
    if shutil.which("objdump") is None:
        print("objdump not found (binutils)", file=sys.stderr)
        return 77
    bad = 0
    for binary in argv[1:]:
        found = kernels(binary)
        if not found:
            print(f"{binary}: no engine kernel found (the pattern no longer matches?)", file=sys.stderr)
            bad += 1
        scalar = sorted((name, n) for name, (n, v) in found.items() if v == 0)
        for name, n in scalar:
            print(f"{binary}: scalar ({n} instructions, none on ymm): {name[:200]}", file=sys.stderr)
        bad += len(scalar)
        print(f"{binary}: {len(found)} engine kernels, {len(found) - len(scalar)} vectorized")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
