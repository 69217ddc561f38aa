"""Every Warp kernel of warp_cut compiles for CUDA ahead of time (NVRTC; no GPU or driver needed).

Compiled: every module of the ``warp_cut.kernels`` package and every physics variant the
variant families can make (``kernels/variants.py``: ``all_variants``), for the oldest and the
newest architecture we support. A kernel that only builds on the CPU fails here, named with its
module, kernel and architecture. Without a CUDA compiler in the Warp build (a trivial kernel
does not compile) the tests are skipped with that reason.

Cubins go to ``$XDG_CACHE_HOME/warp_cut_aot/<Warp version>`` (default ``~/.cache``): Warp names
them by each module's content hash and skips one that exists, so a warm run compiles only
kernels that changed. See docs/cuda.md.
"""

import ast
import importlib
import os
import pkgutil
from pathlib import Path

import pytest
import warp as wp

import warp_cut
import warp_cut.kernels as kernel_package
from warp_cut.kernels import variants
from warp_cut.kernels.integrate import _make as make_integrate

ARCHS = (75, 90)
"""sm_75 (Turing, the oldest architecture CUDA 13 compiles for) and sm_90 (Hopper)."""


@wp.kernel(module="unique", enable_backward=False)
def _probe(out: wp.array(dtype=wp.int32)):
    out[wp.tid()] = 1


@wp.func_native("""
#if defined(__CUDA_ARCH__)
#error "host only"
#endif
return x;
""")
def _host_only(x: float) -> float: ...


@wp.kernel(module="warp_cut_test.host_only", enable_backward=False)
def uses_host_only_code(a: wp.array(dtype=float)):
    a[wp.tid()] = _host_only(a[wp.tid()])


@wp.kernel(module="warp_cut_test.host_only", enable_backward=False)
def portable(a: wp.array(dtype=float)):
    a[wp.tid()] = 1.0


# ------------------------------------------------------------------ what is compiled
def import_kernel_modules() -> list:
    """Import every module of warp_cut.kernels (families register on import); their names."""
    prefix = kernel_package.__name__ + "."
    names = [info.name for info in pkgutil.iter_modules(kernel_package.__path__, prefix)]
    for name in names:
        importlib.import_module(name)
    return names


def warp_modules() -> dict:
    """Warp module name -> Module, for every module holding kernels: the package's own and
    one per variant."""
    modules = {}
    for name in import_kernel_modules():
        module = wp.get_module(name)
        if module.kernels:
            modules[name] = module
    for kernel in variants.all_variants():
        modules[kernel.module.name] = kernel.module
    return modules


def specialised_calls() -> list:
    """(file, base, flag names) of every literal ``specialised("base", make, flag=...)`` call in
    the sources of warp_cut and warp_cut.kernels."""
    roots = [Path(warp_cut.__file__).parent, Path(kernel_package.__file__).parent]
    calls = []
    for path in sorted(p for root in roots for p in root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if (isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", ""))
                    == "specialised" and node.args and isinstance(node.args[0], ast.Constant)):
                calls.append((path.name, node.args[0].value, sorted(k.arg for k in node.keywords)))
    return calls


# ------------------------------------------------------------------ compiling
def compile_failures(module, arch: int, out_dir) -> list:
    """[] if ``module`` compiles for sm_<arch>, else one line per failing kernel (each kernel
    is compiled alone in a module of its own to find which)."""
    try:
        paths = wp.compile_aot_module(module, arch=arch, module_dir=out_dir)
    except Exception as error:  # NVRTC prints its log to stderr; the test shows it
        culprits = [key for key, kernel in module.kernels.items()
                    if _fails_alone(kernel, arch, out_dir)]
        return [f"module {module.name}, kernel {key}, sm_{arch}: {error}"
                for key in culprits or ["(none alone: the module as a whole)"]]
    missing = [str(p) for p in paths if not Path(p).is_file() or Path(p).stat().st_size == 0]
    return [f"module {module.name}, sm_{arch}: no cubin at {missing}"] if missing else []


def _fails_alone(kernel, arch: int, out_dir) -> bool:
    alone = wp.kernel(kernel.func, module="unique", enable_backward=False)
    try:
        wp.compile_aot_module(alone.module, arch=arch, module_dir=out_dir)
    except Exception:
        return True
    return False


@pytest.fixture(scope="module")
def aot_dir(tmp_path_factory):
    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    path = cache / "warp_cut_aot" / wp.__version__
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:  # a read-only home: compile cold into the test's own directory
        return tmp_path_factory.mktemp("aot")
    return path


def require_cuda_compiler(arch: int, out_dir) -> None:
    """Skip the test unless a trivial kernel compiles for sm_<arch> (always compiled, into a
    fresh ``out_dir``: a cached cubin would not show that the compiler is there)."""
    try:
        wp.compile_aot_module(_probe.module, arch=arch, module_dir=out_dir)
    except Exception as error:
        pytest.skip(f"no CUDA ahead-of-time compilation for sm_{arch} in this Warp build "
                    f"({type(error).__name__}: {error})")


@pytest.fixture(params=ARCHS, ids=lambda a: f"sm_{a}")
def arch(request, tmp_path_factory):
    """An architecture the Warp build can compile for (else the test is skipped)."""
    require_cuda_compiler(request.param, tmp_path_factory.mktemp("probe"))
    return request.param


# ------------------------------------------------------------------ tests
def test_every_kernel_and_variant_compiles_for_cuda(arch, aot_dir):
    modules = warp_modules()
    registered = variants.families()
    variant_modules = {k.module.name for k in variants.all_variants()}
    # the families the solvers use today, and every flag combination of each
    assert {"integrate", "xpbd_predict", "xpbd_finish"} <= set(registered)
    assert len(variant_modules) == sum(2 ** len(flags) for flags in registered.values())
    assert variant_modules <= set(modules)
    assert {"warp_cut.kernels.springs", "warp_cut.kernels.collision"} <= set(modules)
    for name, module in modules.items():
        generic = [key for key, k in module.kernels.items() if k.is_generic and not k.overloads]
        assert not generic, f"{name}: generic kernels without overloads are not compiled: {generic}"
    failures = [line for module in modules.values()
                for line in compile_failures(module, arch, aot_dir)]
    assert not failures, "kernels that do not compile for CUDA:\n" + "\n".join(failures)


def test_every_specialised_call_names_a_registered_family():
    import_kernel_modules()
    registered = variants.families()
    calls = specialised_calls()
    assert calls, "no specialised(...) call found"
    for path, base, flags in calls:
        assert base in registered, f"{path}: specialised({base!r}, ...) is not a registered family"
        assert flags == sorted(registered[base]), f"{path}: {base} flags {flags}"


def test_a_cpu_only_kernel_fails_with_module_and_kernel_named(tmp_path):
    # it builds and runs on the CPU ...
    a = wp.zeros(2, dtype=float, device="cpu")
    wp.launch(uses_host_only_code, dim=2, inputs=[a], device="cpu")
    arch = ARCHS[0]
    require_cuda_compiler(arch, tmp_path / "probe")
    # ... and the CUDA check names it, and only it
    failures = compile_failures(uses_host_only_code.module, arch, tmp_path)
    assert len(failures) == 1, failures
    assert failures[0].startswith(
        f"module warp_cut_test.host_only, kernel uses_host_only_code, sm_{arch}: "), failures


def test_registry_rejects_an_unregistered_maker():
    def make(gravity: bool):
        @wp.kernel
        def k(a: wp.array(dtype=float)):
            a[wp.tid()] = 0.0
        return k

    with pytest.raises(ValueError, match="variant_family"):
        variants.specialised("integrate", make, gravity=True)
    with pytest.raises(TypeError, match="flags"):  # a flag left out
        variants.specialised("integrate", make_integrate, gravity=True)
