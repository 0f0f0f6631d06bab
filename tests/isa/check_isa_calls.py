#!/usr/bin/env python3
"""Fails when vector code built for AVX2 or AVX-512 calls code built for another instruction set.

imukit's hot kernels are compiled several times, for AVX-512, AVX2 and the x86-64 baseline (SSE2),
and the variant is picked at run time (core/isa.hpp). A VEX-encoded variant that calls a function
containing legacy (non-VEX) SSE instructions -- an out-of-line Eigen helper, a lambda, an inline
function whose one linked copy was compiled for the baseline -- makes Intel cores pay the
AVX-SSE transition penalty on every such call (issue 17: the simulator ran 12x slower); AMD cores
do not, so timing on them cannot catch it. This check reads the machine code instead, so it
catches the regression on any CPU.

For every function of each ELF file that contains VEX/EVEX-encoded vector instructions (the AVX2
and AVX-512 variants: the roots), every function it can reach through direct calls and tail
calls inside the file must contain no legacy SSE instruction; an indirect call, or a call into
another shared object other than the few listed in ALLOWED_EXTERNAL, is an error too (its
instruction set cannot be read here). Code that GCC moved to a `.cold` part (throws and failed
assertions, which end the computation) is not followed.

  check_isa_calls.py FILE...                 exit 1 and list the offending call chains
  check_isa_calls.py --expect-violation NAME FILE...
                                             exit 0 only if a root whose name contains NAME
                                             is reported (the checker's own test)
"""
import argparse
import re
import subprocess
import sys

# Calls that may leave the file from a VEX root. glibc resolves mem* at load time (ifunc) to its
# AVX2/EVEX variants on every CPU that runs imukit's AVX2 or AVX-512 code; the rest never return
# to vector code.
ALLOWED_EXTERNAL = {
    "memcpy", "memmove", "memset",
    "__assert_fail", "__stack_chk_fail", "abort",
}

TARGET = re.compile(r"^[0-9a-f]+ <([^>]+?)(\+0x[0-9a-f]+)?>$")


class Function:
    def __init__(self, name):
        self.name = name
        self.legacy_sse = None  # first legacy SSE instruction, for the message
        self.vex = False
        self.calls = []  # (kind, target name or text)


def base_name(name):
    """The function a `.cold` part belongs to."""
    return name[:-len(".cold")] if name.endswith(".cold") else name


# Searched per function over the listing (regular expressions run in C; a Python loop over
# every line of a large binary takes seconds).
HEADER = re.compile(r"^[0-9a-f]+ <(.+)>:$", re.M)
VEX = re.compile(r"\tv[a-z0-9]+ [^\n]*%[xyz]mm")
LEGACY_SSE = re.compile(r"^ *([0-9a-f]+):\t((?!v)[a-z0-9]+ [^\n]*%[xyz]mm[^\n]*)$", re.M)
CALL = re.compile(r"\t(?:(?:bnd|notrack) )?call[a-z]* +([^\n]*)$", re.M)
# A jump to the start of another symbol: a tail call (jumps inside a function carry +0x..).
TAIL = re.compile(r"\t(?:bnd )?j[a-z]+ +[0-9a-f]+ <([^>+]+)>$", re.M)


def parse(path, objdump):
    out = subprocess.run([objdump, "-d", "-w", "--no-show-raw-insn", path], check=True,
                         capture_output=True, text=True).stdout
    functions = {}
    headers = list(HEADER.finditer(out))
    for k, h in enumerate(headers):
        body = out[h.end():headers[k + 1].start() if k + 1 < len(headers) else len(out)]
        fn = functions.setdefault(h.group(1), Function(h.group(1)))
        if "mm" in body:
            fn.vex = fn.vex or VEX.search(body) is not None
            legacy = LEGACY_SSE.search(body)
            if legacy and fn.legacy_sse is None:
                fn.legacy_sse = f"{legacy.group(1)}: {legacy.group(2)}"
        for operands in CALL.findall(body):
            if operands.startswith("*"):
                # An indirect call leaves for code that cannot be read here.
                fn.calls.append(("indirect", operands))
                continue
            t = TARGET.match(operands)
            if t and base_name(t.group(1)) != base_name(fn.name):
                fn.calls.append(("call", t.group(1)))
        for target in TAIL.findall(body):
            # Jumps into the function's own cold part are part of the function.
            if base_name(target) != base_name(fn.name):
                fn.calls.append(("call", target))
    return functions


def demangle(names):
    try:
        out = subprocess.run(["c++filt"], input="\n".join(names), capture_output=True, text=True,
                             check=True).stdout.splitlines()
        return dict(zip(names, out))
    except (OSError, subprocess.CalledProcessError):
        return {n: n for n in names}


def check(path, objdump):
    """Violations in one file: (root, chain, reason)."""
    functions = parse(path, objdump)
    roots = [f for f in functions.values() if f.vex and not f.name.endswith(".cold")]
    violations = []
    for root in roots:
        if root.legacy_sse is not None:
            violations.append((root.name, [root.name],
                               f"mixes VEX and legacy SSE ({root.legacy_sse})"))
        seen = {root.name}
        stack = [(root, [root.name])]
        while stack:
            fn, chain = stack.pop()
            for kind, target in fn.calls:
                if kind == "indirect":
                    violations.append((root.name, chain, f"indirect call {target}"))
                    continue
                if target.endswith("@plt"):
                    if target[:-len("@plt")] not in ALLOWED_EXTERNAL:
                        violations.append((root.name, chain + [target],
                                           "calls outside the file (instruction set unknown)"))
                    continue
                callee = functions.get(target)
                if callee is None or target in seen:
                    continue
                seen.add(target)
                if callee.legacy_sse is not None:
                    violations.append((root.name, chain + [target],
                                       f"legacy SSE ({callee.legacy_sse})"))
                    continue
                stack.append((callee, chain + [target]))
    return roots, sorted(set((r, tuple(c), why) for r, c, why in violations))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--expect-violation", metavar="NAME")
    parser.add_argument("--objdump", default="objdump")
    parser.add_argument("files", nargs="+")
    args = parser.parse_args()
    failed = False
    for path in args.files:
        roots, violations = check(path, args.objdump)
        names = sorted({n for _, chain, _ in violations for n in chain} |
                       {r.name for r in roots})
        pretty = demangle(names)
        print(f"{path}: {len(roots)} functions with VEX code, "
              f"{len(violations)} calls into other instruction sets")
        for root, chain, reason in violations:
            print("  " + "\n    -> ".join(pretty.get(n, n) for n in chain))
            print(f"       {reason}")
        if args.expect_violation is not None:
            hit = any(args.expect_violation in pretty.get(root, root) for root, _, _ in violations)
            if not hit:
                print(f"{path}: expected a violation from a root named like "
                      f"'{args.expect_violation}', found none")
                failed = True
        elif violations:
            failed = True
        if not roots and args.expect_violation is None:
            print(f"{path}: no VEX code at all (are the kernels built for AVX2/AVX-512?)")
            failed = True
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
