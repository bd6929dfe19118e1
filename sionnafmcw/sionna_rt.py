"""The Sionna RT boundary: the one module that imports Dr.Jit, Mitsuba and Sionna RT.

Everything sionnafmcw needs from Sionna RT and its two layers (Mitsuba 3, Dr.Jit) goes through
here, so that an upgrade of Sionna is a change of this file (and of the pins in
``pyproject.toml``) and of nothing else:

* **LLVM set-up and imports**: :func:`~sionnafmcw._llvm.configure_llvm` points Dr.Jit at a usable
  libLLVM before ``drjit`` is first imported; the engines and :mod:`sionnafmcw.materials` take
  ``dr``, ``mi`` and the Sionna names they use from this module.
* **Version check**: :data:`VERIFIED_VERSIONS` are the releases this boundary was verified
  against (the private names it touches below exist there and behave as described). Another
  release raises :class:`UnverifiedVersionError` at import, naming the package, the installed and
  the verified versions and the command that installs the verified one; set the environment
  variable ``SIONNAFMCW_ALLOW_UNVERIFIED=1`` to run anyway (a warning instead).
* **Minimum segment length** (:func:`set_min_segment_length`): Sionna drops path segments shorter
  than ``sionna.rt.constants.MIN_SEGMENT_LENGTH`` (1 cm, meant for communication links), which
  removes every retro-reflected path of a radar (see :mod:`sionnafmcw.engines.path`). The
  constant is copied into each path-solver module at import, so the patch rewrites it there and
  fails loudly when a module no longer has it (a silent miss would stop protecting corner
  reflectors without anyone noticing).
* **Scene loading at the carrier** (:func:`load_scene_at`): Sionna evaluates every ITU material
  at its default frequency (3.5 GHz) while the XML is parsed; materials that ITU-R P.2040
  defines only at millimetre waves then fail to load. The default is set to the carrier for the
  duration of the load.
* **Path-solver steps** (:func:`trace_candidates`, :func:`solve_fields`): the steps of
  ``PathSolver.__call__`` up to the path buffer, without building the ``Paths`` tensors (whose
  kernels bake the per-frame path count in as a constant), with the candidate count read from
  the buffer's public ``paths_counter``.
* **Ray casting** (:func:`cast_rays`): Mitsuba's first-hit query on the loaded scene, with inputs
  in aligned buffers so that the kernels do not change from frame to frame.
* **Kernel tracking** (:func:`track_kernels`): Dr.Jit kernel launches of a block.
* **Element patterns** (:func:`sionna_antenna_pattern`, :func:`drjit_element_gain`): the radar's
  element pattern (:mod:`sionnafmcw.antenna`, one formula on an array namespace) evaluated in
  Dr.Jit, registered with Sionna's antenna-pattern registry under its ``registry_name`` (Sionna's
  own ``"iso"`` and ``"tr38901"`` are used as they are) and used by the PO kernel.
"""

from __future__ import annotations

import os
import threading
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._llvm import configure_llvm

configure_llvm()  # before the first import of drjit: Dr.Jit reads DRJIT_LIBLLVM_PATH when it loads

import drjit as dr  # noqa: E402  (the one place: after the LLVM set-up above)
import mitsuba as mi  # noqa: E402
import sionna.rt as _sionna_rt  # noqa: E402  (sets the Mitsuba variant, registers Sionna's plugins)
import sionna.rt.path_solvers.image_method as _image_method  # noqa: E402
import sionna.rt.path_solvers.sb_candidate_generator as _candidate_generator  # noqa: E402
import sionna.rt.path_solvers.sb_deterministic as _deterministic  # noqa: E402
import sionna.rt.scene as _sionna_scene  # noqa: E402
from sionna.rt import (  # noqa: E402
    AntennaArray, ITURadioMaterial, PathSolver, RadioMaterial, Receiver, Transmitter, load_scene,
)
from sionna.rt.antenna_pattern import (  # noqa: E402
    PolarizedAntennaPattern, antenna_pattern_registry, register_antenna_pattern,
)
from sionna.rt.constants import DEFAULT_THICKNESS, INVALID_SHAPE, InteractionType  # noqa: E402
from sionna.rt.radio_materials.itu import ITU_MATERIALS_PROPERTIES  # noqa: E402
from sionna.rt.radio_materials.scattering_pattern import LambertianPattern  # noqa: E402

# ---------------------------------------------------------------------------------------- versions
#: Releases this module was verified against (``pyproject.toml`` pins the same major.minor).
VERIFIED_VERSIONS = {"sionna-rt": "2.2.0", "mitsuba": "3.9.1", "drjit": "1.5.0"}

#: Environment variable that turns an unverified version into a warning.
ALLOW_UNVERIFIED_ENV = "SIONNAFMCW_ALLOW_UNVERIFIED"


class SionnaBoundaryError(RuntimeError):
    """Sionna RT, Mitsuba or Dr.Jit no longer has what this boundary relies on; the message says what."""


class UnverifiedVersionError(SionnaBoundaryError, ImportError):
    """An installed Sionna RT, Mitsuba or Dr.Jit release this boundary was not verified against."""


def installed_versions() -> dict:
    """The installed versions of the three packages, keyed as :data:`VERIFIED_VERSIONS`."""
    return {"sionna-rt": str(_sionna_rt.__version__), "mitsuba": str(mi.__version__), "drjit": str(dr.__version__)}


def _major_minor(version: str) -> tuple:
    return tuple(version.split(".")[:2])


def check_versions(installed: dict | None = None, allow_unverified: bool | None = None) -> list[str]:
    """Compare ``installed`` (default: :func:`installed_versions`) with :data:`VERIFIED_VERSIONS`.

    A package whose major.minor differs from the verified one raises
    :class:`UnverifiedVersionError` naming the package, both versions and the fix; with
    ``allow_unverified`` (default: the environment variable :data:`ALLOW_UNVERIFIED_ENV` set to
    ``1``) a warning instead. Returns the mismatch messages (empty when all are verified).
    """
    installed = installed_versions() if installed is None else installed
    if allow_unverified is None:
        allow_unverified = os.environ.get(ALLOW_UNVERIFIED_ENV, "") == "1"
    problems = []
    for package, verified in VERIFIED_VERSIONS.items():
        have = installed.get(package)
        if have is None or _major_minor(have) != _major_minor(verified):
            problems.append(
                f"{package} {have} is installed, but sionnafmcw's Sionna boundary (sionnafmcw/sionna_rt.py) was "
                f"verified against {verified}: install it with `pip install '{package}=="
                f"{'.'.join(_major_minor(verified))}.*'`, or set {ALLOW_UNVERIFIED_ENV}=1 to run anyway "
                "(Sionna internals that the engines use may differ)")
    if problems and not allow_unverified:
        raise UnverifiedVersionError("; ".join(problems))
    for problem in problems:
        warnings.warn(problem, stacklevel=2)
    return problems


check_versions()


# ---------------------------------------------------------------------------------------- segment length
#: Sionna's path-solver modules that copy ``MIN_SEGMENT_LENGTH`` at import.
MIN_SEGMENT_LENGTH_MODULES = (_image_method, _candidate_generator, _deterministic)


def set_thread_count(threads: int) -> None:
    """Size of Dr.Jit's thread pool in this process (the LLVM backend's worker threads).

    The LLVM backend launches kernels asynchronously into that pool; the calling thread's kernels
    still in flight are waited for first (``dr.sync_thread``), so that no worker is stopped or
    started under a running kernel."""
    dr.sync_thread()
    dr.set_thread_count(int(threads))


def set_min_segment_length(length: float) -> None:
    """Set Sionna's minimum path segment length (m) in every path-solver module that uses it.

    ``sionna.rt.constants.MIN_SEGMENT_LENGTH`` is imported by name into
    ``sionna.rt.path_solvers.image_method``, ``sb_candidate_generator`` and ``sb_deterministic``,
    and read when their kernels are traced, so set it before the first path is solved; it applies
    to every solver in the process. Raises :class:`SionnaBoundaryError` naming the module when one
    of them no longer has the constant (the protection would otherwise be lost silently).
    """
    length = float(length)
    if not length > 0:
        raise ValueError(f"set_min_segment_length: length must be > 0 m, got {length!r}")
    missing = [m.__name__ for m in MIN_SEGMENT_LENGTH_MODULES if not hasattr(m, "MIN_SEGMENT_LENGTH")]
    if missing:
        raise SionnaBoundaryError(
            f"{', '.join(missing)} has no MIN_SEGMENT_LENGTH any more (verified with sionna-rt "
            f"{VERIFIED_VERSIONS['sionna-rt']}): the radar's minimum segment length cannot be set, and short "
            "retro-reflected paths (corner reflectors) would be dropped; update sionnafmcw/sionna_rt.py "
            "for this Sionna release")
    for module in MIN_SEGMENT_LENGTH_MODULES:
        module.MIN_SEGMENT_LENGTH = length


def min_segment_length() -> dict:
    """The minimum segment length (m) each path-solver module currently uses, by module name."""
    return {m.__name__: getattr(m, "MIN_SEGMENT_LENGTH", None) for m in MIN_SEGMENT_LENGTH_MODULES}


# ---------------------------------------------------------------------------------------- scene loading
_LOAD_LOCK = threading.Lock()


def load_scene_at(xml, frequency: float):
    """Load the scene XML ``xml`` with ``merge_shapes=False`` with every material built at ``frequency`` (Hz).

    Sionna builds each ITU material while the XML is parsed, at
    ``sionna.rt.scene.DEFAULT_FREQUENCY`` (3.5 GHz), before the caller can set the scene's
    frequency; that default is set to ``frequency`` for the duration of the load (restored
    afterwards, also on error, under a lock). Mitsuba's warnings about the PLY velocity properties
    are silenced while loading. Sionna's own exception propagates.
    """
    if not hasattr(_sionna_scene, "DEFAULT_FREQUENCY"):
        raise SionnaBoundaryError(
            "sionna.rt.scene has no DEFAULT_FREQUENCY any more: scenes cannot be loaded at the carrier; "
            "update sionnafmcw/sionna_rt.py for this Sionna release")
    old_level = mi.log_level()
    with _LOAD_LOCK:
        old_default = _sionna_scene.DEFAULT_FREQUENCY
        _sionna_scene.DEFAULT_FREQUENCY = float(frequency)
        mi.set_log_level(mi.LogLevel.Error)  # PLY vx/vy/vz properties make Mitsuba warn
        try:
            return load_scene(str(Path(xml)), merge_shapes=False)
        finally:
            _sionna_scene.DEFAULT_FREQUENCY = old_default
            mi.set_log_level(old_level)


# ---------------------------------------------------------------------------------------- path solver
@dataclass
class Candidates:
    """The candidate paths of one :func:`trace_candidates` call and the solver inputs they were traced with.

    ``found`` is the number of candidates the generator counted (the buffer's ``paths_counter``),
    ``capacity`` the buffer size; ``found >= capacity`` means candidates were dropped.
    """

    buffer: object
    found: int
    capacity: int
    src_positions: object
    tgt_positions: object
    src_orientations: object
    tgt_orientations: object
    src_patterns: object
    tgt_patterns: object


def trace_candidates(solver, scene, *, samples_per_src: int, max_num_paths_per_src: int, max_depth: int,
                     specular_reflection: bool, diffuse_reflection: bool, refraction: bool, diffraction: bool,
                     seed: int) -> Candidates:
    """The first step of ``PathSolver.__call__`` (no line of sight): candidate paths of ``scene``.

    Flushes pending parameter updates (``dr.eval()``, so every frame has the same kernel
    partition), takes the scene's sources and targets, one per array element
    (``synthetic_array=False``; the path engine's coherent model gives each array one element), as
    opaque values, runs the solver's candidate generator and evaluates the buffer. The caller checks
    :attr:`Candidates.found` against :attr:`Candidates.capacity` before :func:`solve_fields`.
    """
    scene.all_set(radio_map=False)
    dr.eval()  # flush the frame's parameter updates: same kernel partition in every frame
    src_positions, src_orientations, _, _ = scene.sources(False, True)
    tgt_positions, tgt_orientations, _, _ = scene.targets(False, True)
    src_patterns = scene.tx_array.antenna_pattern.patterns
    tgt_patterns = scene.rx_array.antenna_pattern.patterns
    dr.make_opaque(src_positions, tgt_positions, src_orientations, tgt_orientations)
    buf = solver._candidate_generator(
        mi_scene=scene.mi_scene, src_positions=src_positions, tgt_positions=tgt_positions,
        samples_per_src=samples_per_src, max_num_paths_per_src=max_num_paths_per_src,
        max_depth=max_depth, los=False, specular_reflection=specular_reflection,
        diffuse_reflection=diffuse_reflection, refraction=refraction, diffraction=diffraction,
        edge_diffraction=False, seed=seed)
    buf.schedule()
    dr.eval()
    return Candidates(buf, int(buf.paths_counter[0]), int(buf.buffer_size), src_positions, tgt_positions,
                      src_orientations, tgt_orientations, src_patterns, tgt_patterns)


def solve_fields(solver, scene, candidates: Candidates, *, samples_per_src: int, diffraction: bool):
    """The rest of ``PathSolver.__call__`` up to the path buffer: image method, fields, valid paths only.

    Shrinks the candidate buffer to the paths found, runs the solver's image method and field
    calculator and discards the invalid paths; returns Sionna's ``PathsBuffer``.
    """
    buf = candidates.buffer
    buf.shrink()
    buf.detach_geometry()
    buf = solver._image_method(scene=scene.mi_scene, paths=buf, src_positions=candidates.src_positions,
                               tgt_positions=candidates.tgt_positions, diffraction=diffraction,
                               diffraction_lit_region=True)
    buf = solver._field_calculator(
        wavelength=scene.wavelength, paths=buf, samples_per_src=samples_per_src,
        diffraction=diffraction, src_positions=candidates.src_positions, tgt_positions=candidates.tgt_positions,
        src_orientations=candidates.src_orientations, tgt_orientations=candidates.tgt_orientations,
        src_antenna_patterns=candidates.src_patterns, tgt_antenna_patterns=candidates.tgt_patterns)
    buf.discard_invalid()
    return buf


# ---------------------------------------------------------------------------------------- element patterns
class DrJitOps:
    """:class:`sionnafmcw.antenna.NumpyOps` for Dr.Jit arrays (any float type of any backend)."""

    minimum = staticmethod(dr.minimum)
    maximum = staticmethod(dr.maximum)
    floor = staticmethod(dr.floor)

    @staticmethod
    def clip(x, lo, hi):
        return dr.clip(x, lo, hi)

    @staticmethod
    def gather(table, index):
        """``table[index]`` with ``index`` a float array holding whole numbers (a numpy table of values)."""
        kind = type(index)
        values = _table_cache(id(table), kind, table)
        return dr.gather(kind, values, dr.uint32_array_t(kind)(index))


_TABLES: dict = {}


def _table_cache(key, kind, table):
    """A numpy table as a Dr.Jit array of ``kind`` (kept per table and type: the same buffer every call)."""
    entry = _TABLES.get((key, kind))
    if entry is None or entry[0] is not table:
        entry = _TABLES[(key, kind)] = (table, kind(np.asarray(table, dtype=np.float64)))
    return entry[1]


DRJIT = DrJitOps()


def drjit_element_gain(pattern, x, y, z):
    """Linear power gain of ``pattern`` (a ``RadarConfig.antenna_pattern`` value) towards the radar-frame
    direction ``(x, y, z)`` (Dr.Jit arrays): :func:`sionnafmcw.antenna.antenna_gain`'s formula in Dr.Jit."""
    from .antenna import element_pattern

    theta = dr.acos(dr.clip(z / dr.sqrt(x * x + y * y + z * z), -1.0, 1.0))
    phi = dr.atan2(y, x)
    g_db = element_pattern(pattern).gain_db(theta, phi, DRJIT)
    return dr.exp2(g_db * float(np.log2(10.0) / 10.0))


def _v_pattern(element):
    """Sionna's vertically polarised pattern function of an :class:`~sionnafmcw.antenna.ElementPattern`."""

    def v_pattern(theta, phi):
        g_db = element.gain_db(theta, phi, DRJIT)
        return mi.Complex2f(dr.sqrt(dr.exp2(g_db * float(np.log2(10.0) / 10.0))), 0)

    return v_pattern


def sionna_antenna_pattern(pattern, polarization: str = "V"):
    """Sionna's ``AntennaPattern`` of ``pattern`` (a ``RadarConfig.antenna_pattern`` value): Sionna's own for
    ``"iso"`` and ``"tr38901"``, otherwise the pattern's formula registered (once) under its
    ``registry_name`` with Sionna's ``register_antenna_pattern``."""
    from .antenna import element_pattern

    element = element_pattern(pattern)
    name = element.registry_name
    if name not in antenna_pattern_registry.list():
        v_pattern = _v_pattern(element)

        def factory(*, polarization, polarization_model="tr38901_2"):
            return PolarizedAntennaPattern(v_pattern=v_pattern, polarization=polarization,
                                           polarization_model=polarization_model)

        register_antenna_pattern(name, factory)
    return antenna_pattern_registry.get(name)(polarization=polarization)


# ---------------------------------------------------------------------------------------- kernels
@dataclass
class KernelCounts:
    """Dr.Jit JIT kernels of a :func:`track_kernels` block (all 0 when not tracked).

    ``launched``: kernels run; ``compiled``: those found neither in Dr.Jit's in-memory nor on-disk
    cache; ``new``: kernels whose hash was not in ``seen_hashes`` before the block.
    """

    launched: int = 0
    compiled: int = 0
    new: int = 0


def aligned_float(values) -> "mi.Float":
    """``values`` as a Dr.Jit Float from a 64-byte aligned, padded float32 copy (:func:`aligned_copy`).

    Dr.Jit reads numpy memory as it is and compiles the alignment of each input into the
    kernel (``align 1`` vs ``align 64``): inputs with varying alignment would give the same
    ray cast a new kernel hash (a recompilation) from frame to frame.
    """
    return mi.Float(aligned_copy(values, np.float32))


#: Elements after its end that a Dr.Jit LLVM kernel may read of an input array (:func:`aligned_copy`).
LLVM_TAIL_PAD = 32


def aligned_copy(values, dtype) -> np.ndarray:
    r"""A flat copy of ``values`` as ``dtype``, its first element 64-byte aligned and followed by
    :data:`LLVM_TAIL_PAD` readable elements (zeros).

    Dr.Jit's LLVM backend maps a contiguous numpy array without a copy (the Dr.Jit array and the
    numpy array share memory), and its kernels load their inputs in whole vectors of :math:`W`
    lanes (:math:`W = 16` with AVX-512, 8 with AVX2), the last vector included: for an array of
    :math:`n` elements a kernel reads up to element :math:`W\lceil n/W\rceil - 1`, i.e. up to
    :math:`W - 1` elements past the end (the lanes beyond :math:`n` are masked out of the result,
    not out of the load). Dr.Jit's own allocations are padded for this; a numpy array is not, and
    one that ends at the end of its memory mapping (a large array is mapped by itself, and its end
    meets the mapping's end where its size plus the allocator's header is a whole number of pages)
    makes the kernel read an unmapped page: a segmentation fault, on AVX-512 machines for arrays
    ending within 60 (float32) or 120 (float64) bytes of a page end. Every numpy array handed to a
    Dr.Jit kernel goes through this copy (:func:`aligned_float`, :func:`aligned_float64`,
    :func:`drjit_array`); ``tests/test_drjit_inputs.py`` shows the fault on an unpadded array ending
    at a guard page and none through this copy.
    """
    values = np.asarray(values, dtype=dtype).ravel()
    buffer = np.empty(values.size + 64 // np.dtype(dtype).itemsize + LLVM_TAIL_PAD, dtype=dtype)
    start = (-buffer.ctypes.data % 64) // buffer.itemsize
    aligned = buffer[start:start + values.size]
    aligned[:] = values
    buffer[start + values.size:] = 0
    return aligned


def drjit_array(array_type, values, dtype):
    """``values`` as the Dr.Jit ``array_type`` (e.g. ``mi.UInt32``, ``drjit.llvm.Int32``) from an
    :func:`aligned_copy` as numpy ``dtype`` (the type's element type)."""
    return array_type(aligned_copy(values, dtype))


def array_backend():
    """The Dr.Jit array namespace of the Mitsuba variant: ``drjit.cuda`` or ``drjit.llvm`` (their
    plain, non-differentiable types: ``Float64``, ``UInt32``, ...), for kernels of sionnafmcw's own."""
    import drjit.cuda
    import drjit.llvm

    return drjit.cuda if mi.variant().startswith("cuda") else drjit.llvm


def aligned_float64(values, backend=None):
    """``values`` as a Dr.Jit ``Float64`` of ``backend`` (default :func:`array_backend`) from a
    64-byte aligned float64 copy (see :func:`aligned_float`: the alignment is compiled into kernels)."""
    return (backend or array_backend()).Float64(aligned_copy(values, np.float64))


def cast_rays(scene, origins, directions, shading_normals: bool = False) -> tuple:
    """First hits of rays ``origins [K, 3]`` (or one ``[3]``) + t ``directions [K, 3]`` on a Sionna ``scene``.

    Mitsuba's preliminary intersection of the scene's ``mi_scene`` (:func:`cast_scene`).
    """
    return cast_scene(scene.mi_scene, origins, directions, shading_normals)


def cast_scene(mi_scene, origins, directions, shading_normals: bool = False, maxt=None) -> tuple:
    """First hits of rays ``origins [K, 3]`` (or one ``[3]``) + t ``directions [K, 3]`` on a Mitsuba scene.

    Mitsuba's preliminary intersection (world frame of that scene, the caller's float64 arrays cast
    to float32), with ``0 <= t <= maxt`` (``[K]``, default unbounded). Returns numpy arrays ``(valid [K] bool, t [K], shape_id [K], triangle [K],
    barycentric [K, 2])``; ``shape_id`` is the hit shape's pointer reinterpreted as an integer (a
    Sionna object's ``object_id``); with ``shading_normals`` also Mitsuba's shading normal of each
    hit ``[K, 3]`` (the interpolated vertex normal where the mesh has them, else the facet normal;
    unit, zero where there is no hit).
    """
    directions = np.asarray(directions, float)
    k = directions.shape[0]
    origins = np.broadcast_to(np.asarray(origins, float), (k, 3))
    ray = mi.Ray3f(mi.Point3f(*[aligned_float(origins[:, i]) for i in range(3)]),
                   mi.Vector3f(*[aligned_float(directions[:, i]) for i in range(3)]))
    if maxt is not None:
        ray.maxt = aligned_float(np.broadcast_to(np.asarray(maxt, float), (k,)))
    pi = mi_scene.ray_intersect_preliminary(ray, coherent=True)
    valid = pi.is_valid()
    shape_id = dr.reinterpret_array(mi.UInt32, pi.shape)
    outputs = [pi.t, pi.prim_index, pi.prim_uv, shape_id, valid]
    if shading_normals:
        n = pi.compute_surface_interaction(ray).sh_frame.n
        outputs.append(n)
    dr.eval(*outputs)
    with np.errstate(invalid="ignore"):  # rays that miss carry undefined (NaN) barycentrics; ``valid`` masks them
        uv = np.stack([np.asarray(pi.prim_uv.x.numpy(), dtype=np.float64),
                       np.asarray(pi.prim_uv.y.numpy(), dtype=np.float64)], axis=-1)
    result = (np.asarray(valid.numpy(), dtype=bool), np.asarray(pi.t.numpy(), dtype=np.float64),
              np.asarray(shape_id.numpy(), dtype=np.int64), np.asarray(pi.prim_index.numpy(), dtype=np.int64), uv)
    if shading_normals:
        normal = np.stack([np.asarray(c.numpy(), dtype=np.float64) for c in (n.x, n.y, n.z)], axis=-1)
        norm = np.linalg.norm(normal, axis=-1, keepdims=True)
        normal = np.divide(normal, norm, out=np.zeros_like(normal), where=norm > 0)
        result = result + (normal,)
    return result


@contextmanager
def track_kernels(enabled: bool, seen_hashes: set):
    """Count the Dr.Jit kernels launched in the ``with`` block; yields a :class:`KernelCounts`.

    With ``enabled`` the ``KernelHistory`` flag is set and the history cleared on entry; the flag
    gets its previous value back on exit (also on error). On a normal exit the counts are filled
    in and the block's kernel hashes added to ``seen_hashes`` (the caller's set, kept across calls).
    """
    counts = KernelCounts()
    history_flag = dr.flag(dr.JitFlag.KernelHistory)
    if enabled:
        dr.set_flag(dr.JitFlag.KernelHistory, True)
        dr.kernel_history_clear()
    try:
        yield counts
    finally:
        if enabled:
            history = dr.kernel_history()
            dr.set_flag(dr.JitFlag.KernelHistory, history_flag)
    if enabled:
        jit = [k for k in history if k["type"] == dr.KernelType.JIT]
        hashes = {k["hash"] for k in jit}
        counts.launched = len(jit)
        counts.compiled = sum(1 for k in jit if not k.get("cache_hit", False))
        counts.new = len(hashes - seen_hashes)
        seen_hashes |= hashes


__all__ = [
    "ALLOW_UNVERIFIED_ENV", "AntennaArray", "Candidates", "DEFAULT_THICKNESS", "INVALID_SHAPE", "ITURadioMaterial",
    "ITU_MATERIALS_PROPERTIES", "InteractionType", "KernelCounts", "LLVM_TAIL_PAD", "LambertianPattern",
    "MIN_SEGMENT_LENGTH_MODULES", "PathSolver", "RadioMaterial", "Receiver", "SionnaBoundaryError", "Transmitter",
    "UnverifiedVersionError", "VERIFIED_VERSIONS", "DRJIT", "DrJitOps", "aligned_copy", "aligned_float",
    "aligned_float64", "antenna_pattern_registry", "array_backend", "cast_rays", "cast_scene", "check_versions", "dr",
    "drjit_array", "drjit_element_gain", "installed_versions", "load_scene_at", "sionna_antenna_pattern",
    "mi", "min_segment_length", "set_min_segment_length", "solve_fields", "trace_candidates", "track_kernels",
]
