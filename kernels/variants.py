"""Kernels specialised per enabled-physics set.

A node kernel that may add gravity or test the tool is written once, with ``wp.static`` flags,
in a function ``make(**flags)`` that returns it. ``@variant_family("integrate")`` registers that
function when its module is imported (the flags are its parameters, all booleans);
``specialised`` turns it into one kernel per flag set, each in its own Warp module named after
what it contains (``warp_cut.kernels.integrate_gravity_collision``), with the module options the
family was registered with. A Warp module compiles on its first launch, so a scene never compiles
the code of physics it disables.

``all_variants`` yields the kernel of every flag combination of every registered family, so a
check (the CUDA ahead-of-time test) can compile what no scene has asked for yet.
"""

import inspect
import itertools

import warp as wp

_FAMILIES = {}
"""base name -> (make, flag names in the order of make's parameters)."""
_CACHE = {}


def variant_family(base: str, options: dict | None = None):
    """Decorator registering ``make(**flags)`` as the variant family ``base``; the names of
    its parameters are the family's (boolean) flags. ``options``: Warp module options set on
    every variant's module (``wp.set_module_options``)."""

    def register(make):
        known = _FAMILIES.get(base)
        if known is not None and known[0].__qualname__ != make.__qualname__:
            raise ValueError(f"variant family {base!r} is already made by "
                             f"{known[0].__module__}.{known[0].__qualname__}")
        _FAMILIES[base] = (make, tuple(inspect.signature(make).parameters), dict(options or {}))
        return make

    return register


def contracted_cpu_math() -> dict:
    """Module options that let the CPU compiler fuse a multiply and an add into one FMA across
    statements (``-ffp-contract=fast``), as CUDA does by default: Warp writes each operation as
    its own statement, so its ``fuse_fp`` alone fuses nothing on the CPU. One rounding instead of
    two; NaN and inf propagate as before. Empty on Warp versions without CPU compiler flags."""
    flags = getattr(wp.config, "cpu_compiler_flags", None)
    return {"cpu_compiler_flags": f"{flags} -ffp-contract=fast"} if flags else {}


def specialised(base: str, make, **flags):
    """The kernel ``make(**flags)`` returns, registered as module ``warp_cut.kernels.<base>``
    plus ``_<flag>`` for every flag that is on (cached per flag set). ``make`` must be
    registered with ``@variant_family(base)`` and ``flags`` must name all its flags."""
    family = _FAMILIES.get(base)
    if family is None or family[0] is not make:
        raise ValueError(f"{make.__qualname__} is not registered as variant family {base!r}: "
                         f"decorate it with @variant_family({base!r})")
    names = family[1]
    if set(flags) != set(names):
        raise TypeError(f"variant family {base!r} takes the flags {list(names)}, got {sorted(flags)}")
    values = {name: bool(flags[name]) for name in names}
    key = (base, tuple(values.values()))
    if key not in _CACHE:
        suffix = "".join(f"_{name}" for name, on in values.items() if on)
        module = f"warp_cut.kernels.{base}{suffix}"
        _CACHE[key] = wp.kernel(make(**values), enable_backward=False, module=module, name=f"{base}{suffix}")
        if family[2]:
            wp.set_module_options(family[2], module=module)
    return _CACHE[key]


def families() -> dict:
    """Registered families (of the kernel modules imported so far): base name -> flag names."""
    return {base: names for base, (_, names, _) in _FAMILIES.items()}


def all_variants():
    """Yield every kernel the registered families can make: 2 ** (flag count) per family."""
    for base, (make, names, _) in sorted(_FAMILIES.items()):
        for values in itertools.product((False, True), repeat=len(names)):
            yield specialised(base, make, **dict(zip(names, values)))
