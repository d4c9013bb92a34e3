#!/usr/bin/env python3
"""Reads QEMU's `-d exec,nochain,in_asm` log from stdin and writes, per function and per stage,
the instructions executed (see firmware-sim/profile); given a second argument, the hottest blocks
into that file, with the source they were inlined from where a third names the firmware's ELF."""
import collections
import re
import subprocess
import sys

FILT = "arm-none-eabi-c++filt"

STAGES = [
    # (stage, prefixes of the demangled path), first match wins
    ("detection: sky model", ("imade_core::segment::background",)),
    ("detection: labeling", ("imade_core::segment::label", "imade_core::segment::Segmenter>::labeled_candidates")),
    ("detection: bar search", ("imade_core::segment::bar",)),
    ("detection: corridor, terrain, selection, mask", ("imade_core::segment",)),
    ("silhouette: cross-section fits", ("imade_core::extremes::cross_profile",)),
    ("silhouette: width profile", ("imade_core::extremes::axial_profile",)),
    ("silhouette: ends, orientation", ("imade_core::extremes",)),
    ("closed form", ("imade_core::closed_form",)),
    ("table match: Lambertian section fit", ("imade_core::table_match::section",)),
    ("table match: profile matching", ("imade_core::table_match::search",)),
    ("table match: the rest", ("imade_core::table_match", "imade_core::lut")),
    ("grey-level fit", ("imade_core::grey_fit",)),
    ("least squares", ("imade_core::math::least_squares", "imade_core::math::accumulate")),
    ("normal CDF", ("imade_core::math::normal",)),
    ("flight filter", ("imade_core::flight_filter",)),
    ("temporal, range filter, track", ("imade_core::temporal", "imade_core::range_filter", "imade_core::track")),
    ("world frame", ("imade_core::world",)),
    ("pipeline (stages inlined into process)", ("imade_core::pipeline",)),
    ("uncertainty", ("imade_core::uncertainty",)),
    ("memset, memcpy", ("memset", "memcpy", "memclr", "memmove", "__aeabi_mem")),
    ("soft f64 and libm", ("__aeabi_d", "__adddf3", "__muldf3", "__divdf3", "__subdf3", "compiler_builtins", "libm")),
    ("nalgebra", ("nalgebra",)),
    ("the model file, validated once at start", ("imade_core::model",)),
    ("pipeline code inlined into the firmware's `process`", ("imade_firmware::process",)),
    ("firmware I/O and start-up (outside the per-frame count)",
     ("imade_firmware", "imade_pack", "semihosting", "defmt", "cortex_m", "core::fmt", "core::num::imp::flt2dec", "Reset")),
]


# The runtime's helpers (memset/memcpy and kin, software floating point, libm), whose
# instructions are also counted for the function that called them. In v0 mangling a crate's name
# comes with its length: `17compiler_builtins`, `4libm`.
HELPER = re.compile(rb"mem(set|cpy|clr|move)|__aeabi_|17compiler_builtins|4libm")


def demangled(symbols):
    """The Rust names of `symbols` (binutils' c++filt reads v0 mangling), crate hashes dropped."""
    text = subprocess.run([FILT], input="\n".join(symbols), capture_output=True, text=True,
                          check=True).stdout
    return [re.sub(r"\[[0-9a-f]+\]|<(\d+: usize(, )?)+>", "", name) for name in text.splitlines()]


def function_names(addresses, symbol):
    """The Rust names of the functions the blocks at `addresses` lie in."""
    return demangled([symbol.get(a, b"?").decode() for a in addresses])


def stage_of(path):
    plain = path.lstrip("<")  # `<Type as Trait>::f` is the type's
    for stage, prefixes in STAGES:
        if plain.startswith(prefixes):
            return stage
    return "other"


def main():
    executed = collections.Counter()  # block start address -> times executed
    size = {}  # block start address -> instructions in the block
    symbol = {}
    # The helpers' blocks, and their instructions per calling block: the last block executed
    # outside them.
    helpers = set()
    helped = collections.Counter()
    caller = b"?"
    block, count = None, 0
    for line in sys.stdin.buffer:
        if line.startswith(b"Trace"):
            address = line.split(b"/", 2)[1]
            executed[address] += 1
            if address in helpers:
                helped[caller] += size[address]
            else:
                caller = address
        elif line.startswith(b"0x"):
            if block is None:
                block = line[2:10]
            count += 1
        elif line.startswith(b"IN:"):
            block, count = None, 0
            name = line[3:].strip()
        elif block is not None and not line.strip():
            size[block] = count
            symbol[block] = name
            if HELPER.search(name):
                helpers.add(block)
            block = None
    raw = collections.Counter()
    for address, times in executed.items():
        raw[symbol.get(address, b"?").decode()] += times * size.get(address, 0)
    per_function = collections.Counter()
    for function, n in zip(demangled(list(raw)), raw.values()):
        per_function[function] += n
    per_stage = collections.Counter()
    for function, n in per_function.items():
        per_stage[stage_of(function)] += n
    total = sum(per_function.values())
    frames = int(sys.argv[1]) if len(sys.argv) > 1 else 1
    print(f"instructions executed: {total} over {frames} frames, {total / frames:,.0f} a frame\n")
    def table(heading, rows, name=lambda key: f"`{key}`"):
        print(f"| {heading} | instructions a frame | share |\n| --- | ---: | ---: |")
        for key, n in rows:
            print(f"| {name(key)} | {n / frames:,.0f} | {100 * n / total:.1f} % |")

    table("stage", per_stage.most_common(), name=str)
    print()
    table("function", per_function.most_common(40))
    by_caller = collections.Counter()
    callers = list(helped)
    for address, name in zip(callers, function_names(callers, symbol)):
        by_caller[name] += helped[address]
    print()
    table("memset, memcpy, software floating point and libm called from", by_caller.most_common(15))
    if len(sys.argv) > 2:
        elf = sys.argv[3] if len(sys.argv) > 3 else None
        write_blocks(sys.argv[2], executed, size, symbol, frames, total, elf)


def write_blocks(path, executed, size, symbol, frames, total, elf):
    """The hottest blocks (for reading against `arm-none-eabi-objdump -d`) into `path`, each with
    the project's source it was inlined from (`elf`'s debug information)."""
    weight = {a: times * size.get(a, 0) for a, times in executed.items()}
    hottest = sorted(weight, key=weight.get, reverse=True)[:80]
    names = function_names(hottest, symbol)
    sources = inlined_from(elf, hottest) if elf else {}
    with open(path, "w") as out:
        out.write("| block | function | inlined from (innermost first) | instructions | runs a frame "
                  "| instructions a frame | share |\n")
        out.write("| --- | --- | --- | ---: | ---: | ---: | ---: |\n")
        for address, name in zip(hottest, names):
            n = weight[address]
            out.write(f"| 0x{address.decode()} | `{name}` | {sources.get(address, '')} | "
                      f"{size.get(address, 0)} | {executed[address] / frames:,.0f} | "
                      f"{n / frames:,.0f} | {100 * n / total:.1f} % |\n")


def inlined_from(elf, addresses):
    """Per address, the project's source lines its code was inlined from, innermost first
    (`file:line`; past three, the two innermost and the outermost), from binutils'
    `arm-none-eabi-addr2line -i`."""
    text = subprocess.run(
        ["arm-none-eabi-addr2line", "-a", "-i", "-e", elf] + ["0x" + a.decode() for a in addresses],
        capture_output=True, text=True, check=False).stdout
    chains, current = {}, None
    for line in text.splitlines():
        if line.startswith("0x"):
            current = line[2:].lower().encode().rjust(8, b"0")[-8:]
            chains[current] = []
        elif current is not None and "/src/" in line and "/rustlib/" not in line:
            # The repository's own files: core/src/..., firmware-sim/src/...
            where = re.sub(r".*?/((core|firmware-sim|host)/src/.*?)( \(discriminator \d+\))?$", r"\1", line)
            if where not in chains[current]:
                chains[current].append(where)
    shown = {a: chain if len(chain) <= 3 else chain[:2] + ["...", chain[-1]]
             for a, chain in chains.items()}
    return {a: " < ".join(chain) for a, chain in shown.items()}

main()
