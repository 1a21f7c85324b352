"""Sizing an assembly's solve before any meshing: the whole mesh's element count at an edge h
(:func:`check_assembly_size`, from the filleted outlines' areas and perimeters) and the memory it would
take (:func:`check_assembly_memory`, measured bytes per element against what the machine has).

Used by ``simulate_assembly`` and by a kit's prediction alike. Units: mm, bytes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from fabpat.assembly.spec.types import AssemblySpec
    from fabpat.geometry.outline import Outline

#: peak memory of an assembly solve per plate element (bytes) and its fixed part: measured with
#: ``/usr/bin/time -v`` on 1 × 3 and 1 × 12 strips of 0x0488 (0.8 mm plates) through simulate_assembly at
#: h = 3 mm: 1 476 and 5 904 elements, 198 MB and 466 MB maximum resident set, i.e. 60.5 kB per element
#: over 109 MB (the graded 2 × 15 strip, ≈ 19 000 elements, peaked near 1.2 GB, on the same line);
#: rounded up. A scenario solve needs about 40 kB per element (fabpat.simulation.mesh.DEFAULT_MAX_ELEMENTS).
ASSEMBLY_BYTES_PER_ELEMENT = 62_000
ASSEMBLY_BASE_BYTES = 120_000_000


def _rlimit_room() -> list[int]:
    """Bytes left under this process's own limits: the address space (``ulimit -v``, RLIMIT_AS) less its
    VmSize, the data segment (RLIMIT_DATA) less its VmData (``/proc/self/status``); empty when unlimited."""
    import resource
    from pathlib import Path

    used: dict[str, int] = {}
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            key, _, value = line.partition(":")
            if key in ("VmSize", "VmData"):
                used[key] = int(value.split()[0]) * 1024
    except (OSError, ValueError, IndexError):
        return []
    room = []
    for limit, key in ((resource.RLIMIT_AS, "VmSize"), (resource.RLIMIT_DATA, "VmData")):
        soft = resource.getrlimit(limit)[0]
        if soft != resource.RLIM_INFINITY and key in used:
            room.append(max(0, int(soft) - used[key]))
    return room


def available_memory() -> int | None:
    """Bytes of memory this process may still use: the kernel's MemAvailable (``/proc/meminfo``), or the
    room left under a cgroup v2 memory limit or under the process's own limits (``ulimit -v``: a 1 × 1000
    strip under a 6 GB limit died of a MemoryError; :func:`_rlimit_room`) if smaller; None where none is
    known."""
    from pathlib import Path

    found: list[int] = list(_rlimit_room())
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if limit != "max":
            found.append(int(limit) - int(Path("/sys/fs/cgroup/memory.current").read_text().strip()))
    except (OSError, ValueError):
        pass
    return min(found) if found else None


def check_assembly_memory(elements: float, what: str) -> float:
    """Refuse (GeometryError, one line naming the estimate and the memory available) a solve of ``elements``
    plate elements whose estimated peak memory, :data:`ASSEMBLY_BASE_BYTES` + :data:`ASSEMBLY_BYTES_PER_ELEMENT`
    × elements, exceeds :func:`available_memory`; returns the estimate (bytes). ``what`` starts the message."""
    from fabpat.errors import GeometryError

    need = ASSEMBLY_BASE_BYTES + ASSEMBLY_BYTES_PER_ELEMENT * float(elements)
    room = available_memory()
    if room is not None and need > room:
        raise GeometryError(f"{what}: the solve would need about {need / 1e9:.1f} GB of memory ({elements:.0f} "
                            f"elements × {ASSEMBLY_BYTES_PER_ELEMENT / 1e3:g} kB), more than the {room / 1e9:.1f} GB "
                            "available to this process (free memory, a container's or `ulimit -v` limit): use a "
                            "coarser h or a smaller assembly")
    return need


def check_assembly_size(spec: AssemblySpec, patterns: list[str], h: float, max_elements: int,
                        option: str = "raise it with --max-elements", h_name: str = "h",
                        outlines: dict[tuple[str, int, float], Outline] | None = None) -> float:
    """Refuse (GeometryError, naming --max-elements and an h that passes) an assembly whose plate meshes
    at edge h (mm) would hold more than ``max_elements`` triangles in total, or whose solve would need
    more memory than the machine has (:func:`check_assembly_memory`), before any meshing; the estimate is
    :func:`fabpat.simulation.mesh.estimate_elements` of each distinct filleted outline × its count.
    ``option`` (how to raise the limit) and ``h_name`` (how the caller spells h) word the message;
    ``outlines``: outlines already filleted, by (pattern ID, sides, bridge weight), not filleted again."""
    import math

    from fabpat.assembly.place.placement import build_tiling
    from fabpat.errors import GeometryError
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import estimate_elements
    from fabpat.validate import check, check_size, round_up

    max_elements = int(check("max_elements", max_elements, "max_elements", error=GeometryError))
    from fabpat.patterns.variation import Variation

    count: dict[tuple[str, int, float], int] = {}
    for f, (pid, face) in enumerate(zip(patterns, build_tiling(spec).faces, strict=True)):
        key = (pid, len(face), spec.patterns.bridge_weight_of(f) if spec.patterns else 1.0)
        count[key] = count.get(key, 0) + 1
    area = perimeter = 0.0
    for (pid, sides, w), k in count.items():
        o = (outlines or {}).get((pid, sides, w))
        if o is None:
            pattern = get_pattern(pid, sides, None, spec.tiling.edge)
            o = fillet_pattern(pattern, spec.plates.weight, Variation(w)).outline
        area += k * o.area
        perimeter += k * o.perimeter
    n = estimate_elements(area, perimeter, h)
    c = math.sqrt(3.0) / 4.0
    suggest = (perimeter + math.sqrt(perimeter**2 + 4.0 * max_elements * area / c)) / (2.0 * max_elements)
    check_size(n, max_elements, f"{spec.source}: mesh elements of the whole assembly at {h_name} = {h:g} mm", option,
               f"use {h_name} ≥ {round_up(suggest):g} mm", error=GeometryError)
    check_assembly_memory(n, f"{spec.source}: the whole assembly at {h_name} = {h:g} mm")
    return n
