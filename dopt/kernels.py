"""ctypes front of the C loops in ``_rollout_kernels.c``: reduced FD and feedback rollouts.

The shared library is built at install time (an optional setuptools extension). If it is
missing (no C compiler at install) or the running MuJoCo is not the version its prototypes
were written for, ``load()`` returns None, logs why, and ``RolloutService`` takes the
``mujoco.batch.Batch`` route (same results, slower: docs/DESIGN-NOTES.md, "States and the
rollout service"). The service's C route, ``dopt.rollout_c``, is the one user of ``Kernels``.

Work is split over ``threads`` Python threads, each with its own MjData; ctypes releases the
GIL for the length of every C call.
"""

from __future__ import annotations

import ctypes
import glob
import importlib.machinery
import logging
import os
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np

from dopt.errors import RolloutError
from dopt.stability import Monitor
from dopt.state import StateLayout

log = logging.getLogger(__name__)

#: the MuJoCo release series whose prototypes _rollout_kernels.c declares: 4.0.x (mj_version()
#: // 1000; a patch release keeps the public API: 4.0.1's mujoco.h differs from 4.0.0's only in
#: mjVERSION_HEADER and one added function)
MUJOCO_MINOR = 4000
ABI_VERSION = 6                   # dopt_abi_version() of the C file this front matches
_HERE = os.path.dirname(os.path.abspath(__file__))
_lib = None
_load_error: str | None = None

_p = ctypes.c_void_p
_dbl = np.ctypeslib.ndpointer(np.float64, flags="C_CONTIGUOUS")
_int = np.ctypeslib.ndpointer(np.int32, flags="C_CONTIGUOUS")


class Layout(ctypes.Structure):
    """layout_t of the C file: sizes and offsets of qpos, qvel, ctrl in a state row."""

    _fields_ = [(n, ctypes.c_int) for n in ("nq", "nv", "nu", "nstate", "sig", "qpos", "qvel",
                                             "ctrl", "sig_qposvel", "sig_ctrl")]

    @classmethod
    def of(cls, model: mujoco.MjModel, layout: StateLayout) -> Layout:
        S = mujoco.mjtState
        return cls(model.nq, model.nv, model.nu, layout.size, layout.spec,
                   layout["qpos"].start, layout["qvel"].start, layout["ctrl"].start,
                   int(S.mjSTATE_QPOS) | int(S.mjSTATE_QVEL), int(S.mjSTATE_CTRL))


class Warnings(ctypes.Structure):
    """warnings_t of the C file: an MjData's warning counters, read in place."""

    _fields_ = [("number", ctypes.c_void_p), ("stride", ctypes.c_int), ("n", ctypes.c_int)]

    @classmethod
    def of(cls, data: mujoco.MjData) -> Warnings:
        number = data.warning.number           # a strided view into the mjData
        stride = number.strides[0] // number.itemsize
        if number.itemsize != ctypes.sizeof(ctypes.c_int) or number.strides[0] % number.itemsize:
            raise RuntimeError("unexpected layout of mjData.warning")
        return cls(number.ctypes.data, stride, len(number))


class Bounds(ctypes.Structure):
    """bounds_t of the C file: a ``dopt.stability.Monitor``'s arrays and bounds. Holds
    references to the arrays it points into."""

    _fields_ = [("groups", ctypes.c_void_p), ("ngroup", ctypes.c_int),
                ("planes", ctypes.c_void_p), ("nplane", ctypes.c_int),
                ("radius", ctypes.c_void_p), ("nvert", ctypes.c_int),
                ("length0", ctypes.c_void_p), ("nedge", ctypes.c_int),
                ("iteration_cap", ctypes.c_int), ("max_capped", ctypes.c_int),
                ("max_speed", ctypes.c_double), ("max_penetration", ctypes.c_double),
                ("max_strain", ctypes.c_double),
                ("edge_grasps", ctypes.c_void_p), ("grasp_width", ctypes.c_int),
                ("energy_judged", ctypes.c_int), ("max_energy", ctypes.c_double),
                ("energy_mass", ctypes.c_double), ("window_eqs", ctypes.c_void_p),
                ("nwindow", ctypes.c_int), ("working_act", ctypes.c_void_p),
                ("nworking", ctypes.c_int), ("spin_dofs", ctypes.c_void_p),
                ("spin_radius", ctypes.c_void_p), ("nspin", ctypes.c_int),
                ("spin_width", ctypes.c_int)]

    @classmethod
    def of(cls, monitor: Monitor) -> Bounds:
        keep = [np.ascontiguousarray(monitor.groups, dtype=np.int32),
                np.ascontiguousarray(monitor.planes, dtype=np.float64),
                np.ascontiguousarray(monitor.radius, dtype=np.float64),
                np.ascontiguousarray(monitor.length0, dtype=np.float64),
                np.ascontiguousarray(monitor.edge_grasps, dtype=np.int32),
                np.ascontiguousarray(monitor.window_eqs, dtype=np.int32),
                np.ascontiguousarray(monitor.working_actuators, dtype=np.int32),
                np.ascontiguousarray(monitor.spin_dofs, dtype=np.int32),
                np.ascontiguousarray(monitor.spin_radius, dtype=np.float64)]
        b = monitor.bounds
        out = cls(keep[0].ctypes.data, len(keep[0]), keep[1].ctypes.data, len(keep[1]),
                  keep[2].ctypes.data, len(keep[2]), keep[3].ctypes.data, len(keep[3]),
                  monitor.iteration_cap,
                  -1 if b.max_capped_steps is None else b.max_capped_steps,
                  b.max_speed, b.max_penetration, b.max_strain, keep[4].ctypes.data,
                  keep[4].shape[1], int(monitor.energy_judged),
                  b.max_energy_gain if monitor.energy_judged else 0.0, monitor.energy_mass,
                  keep[5].ctypes.data, len(keep[5]), keep[6].ctypes.data, len(keep[6]),
                  keep[7].ctypes.data, keep[8].ctypes.data, keep[8].shape[0], keep[8].shape[1])
        out._keep = keep
        return out


class Probe(ctypes.Structure):
    """probe_t of the C file: the fields of one MjData the bounds read, in place."""

    _fields_ = [("vert_xpos", ctypes.c_void_p), ("edge_length", ctypes.c_void_p),
                ("niter", ctypes.c_void_p), ("nisland", ctypes.c_int),
                ("eq_active", ctypes.c_void_p), ("energy", ctypes.c_void_p),
                ("actuator_force", ctypes.c_void_p)]

    @classmethod
    def of(cls, data: mujoco.MjData) -> Probe:
        niter = data.solver_niter
        if niter.dtype != np.int32 or not niter.flags.c_contiguous:
            raise RuntimeError("unexpected layout of mjData.solver_niter")
        for f in (data.flexvert_xpos, data.flexedge_length):
            if f.size and not f.flags.c_contiguous:
                raise RuntimeError("unexpected layout of mjData flex fields")
        eq = data.eq_active
        if eq.size and (eq.itemsize != 1 or not eq.flags.c_contiguous):
            raise RuntimeError("unexpected layout of mjData.eq_active")
        for f in (data.energy, data.actuator_force):
            if f.size and not f.flags.c_contiguous:
                raise RuntimeError("unexpected layout of mjData.energy / actuator_force")
        return cls(data.flexvert_xpos.ctypes.data, data.flexedge_length.ctypes.data,
                   niter.ctypes.data, len(niter), eq.ctypes.data, data.energy.ctypes.data,
                   data.actuator_force.ctypes.data)


#: the columns of the C file's per-rollout stats (NSTAT)
STATS = ("speed", "penetration", "strain", "capped", "energy", "value", "index", "low",
         "free")


def _library_path() -> str | None:
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        found = glob.glob(os.path.join(_HERE, "_rollout_kernels" + suffix))
        if found:
            return found[0]
    return None


def load():
    """The kernel library (ctypes.CDLL), or None with the reason logged once."""
    global _lib, _load_error
    if _lib is not None or _load_error is not None:
        return _lib
    if mujoco.mj_version() // 1000 != MUJOCO_MINOR:
        _load_error = (f"MuJoCo {mujoco.mj_version()} is not of the {MUJOCO_MINOR}xxx series "
                       f"the kernel prototypes were written for")
    elif (path := _library_path()) is None:
        _load_error = "dopt/_rollout_kernels was not built (no C compiler at install?)"
    else:
        # make the libmujoco the bindings already loaded global, so the kernel's symbols
        # resolve against that same instance
        libmujoco = glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*"))
        try:
            for lib in libmujoco:
                ctypes.CDLL(lib, mode=os.RTLD_GLOBAL | getattr(os, "RTLD_NOLOAD", 0))
            lib = ctypes.CDLL(path)
            abi = lib.dopt_abi_version() if hasattr(lib, "dopt_abi_version") else None
            if abi != ABI_VERSION:
                _load_error = (f"{path} is a stale build (ABI {abi}, need {ABI_VERSION}): "
                               f"reinstall with pip install -e .")
            else:
                _lib = lib
        except OSError as e:
            _load_error = f"cannot load {path}: {e}"
    if _lib is None:
        log.warning("C rollout kernels unavailable (%s); using mujoco.batch.Batch", _load_error)
        return None
    L, W = ctypes.POINTER(Layout), ctypes.POINTER(Warnings)
    _lib.dopt_fd_work.argtypes = [L]
    _lib.dopt_feedback_work.argtypes = [L, ctypes.c_int]
    _lib.dopt_fd.argtypes = [_p, _p, L, W, _dbl, _int, ctypes.c_int, _int, ctypes.c_int,
                             ctypes.c_double, ctypes.c_int, _dbl, _dbl, _dbl, _dbl, _int]
    B, Pr = ctypes.POINTER(Bounds), ctypes.POINTER(Probe)
    _lib.dopt_feedback.argtypes = [_p, _p, L, W, B, Pr, _dbl, ctypes.c_int, _dbl, _dbl, _dbl,
                                   _int, ctypes.c_int, _dbl, _dbl, _dbl, _dbl, _dbl, _dbl, _int]
    for f in (_lib.dopt_fd_work, _lib.dopt_feedback_work, _lib.dopt_fd, _lib.dopt_feedback):
        f.restype = ctypes.c_int
    _lib.dopt_error_message.restype = ctypes.c_char_p
    _lib.dopt_install_log_handler.restype = None
    _lib.dopt_install_log_handler()     # MuJoCo errors in a kernel call raise, not exit
    return _lib


def load_error() -> str | None:
    """Why ``load()`` returned None (None if it did not, or was not called yet)."""
    return _load_error


class Kernels:
    """The C loops on one model, over ``threads`` MjData and Python threads.

    Calls report the first step that failed, as ``dopt.errors.UnstableRolloutError`` defines
    it (MuJoCo warned during the step, read from the MjData's counters, or the state it left
    is one MuJoCo's checks reject or non-finite), so the caller can name it. Not for
    concurrent use.
    """

    def __init__(self, model: mujoco.MjModel, layout: StateLayout, threads: int,
                 monitor: Monitor | None = None):
        self.lib = load()
        if self.lib is None:
            raise RuntimeError(f"C rollout kernels unavailable: {_load_error}")
        self.model = model
        self.layout = Layout.of(model, layout)
        self.threads = threads
        self.bounds = Bounds.of(monitor or Monitor(model))
        self._datas = [mujoco.MjData(model) for _ in range(threads)]
        self._warnings = [Warnings.of(d) for d in self._datas]
        self._probes = [Probe.of(d) for d in self._datas]
        # close() shuts the workers down (else they exit when the pool is garbage-collected)
        self._pool = ThreadPoolExecutor(threads) if threads > 1 else None

    def close(self) -> None:
        """Shut the thread pool down and drop the MjData; idempotent. No call may follow."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
        self._datas, self._warnings, self._probes = [], [], []

    def _map(self, job, n_items: int):
        """Run job(i, items) on `threads` interleaved shares of range(n_items); share i runs
        on MjData i."""
        shares = [np.arange(i, n_items, self.threads, dtype=np.int32)
                  for i in range(min(self.threads, n_items))]
        if self._pool is None or len(shares) == 1:
            return [job(0, shares[0])]
        return list(self._pool.map(job, range(len(shares)), shares))

    def fd(self, states: np.ndarray, dofs: np.ndarray, eps: float, centered: bool,
           lo: np.ndarray, hi: np.ndarray):
        """F = [A B] (T, 2c, 2c + nu) of state rows (T, ns) on the DoF set dofs (c,).

        Returns (F, bad): bad lists (t, perturbation, reasons) of the first timestep per thread
        one of whose steps failed, with the perturbation row (numbered as in
        ``dopt.rollout_batch``) of that step and the reasons (warning names); empty if none,
        else F is incomplete."""
        T, c, nu = len(states), len(dofs), self.model.nu
        F = np.empty((T, 2 * c, 2 * c + nu))
        C = np.ascontiguousarray(dofs, dtype=np.int32)
        lay = ctypes.byref(self.layout)
        work_n = self.lib.dopt_fd_work(lay)
        m = self.model._address

        def job(i, ts):
            d, work, info = self._datas[i], np.empty(work_n), np.zeros(2, np.int32)
            d.warning.number[:] = 0
            t = self.lib.dopt_fd(m, d._address, lay, ctypes.byref(self._warnings[i]), states,
                                 ts, len(ts), C, c, eps, int(centered), lo, hi, F, work, info)
            if t <= -2:
                raise RolloutError(f"derivatives t={-2 - t}: MuJoCo error: {self._recover(i)}")
            return [] if t < 0 else [(t, int(info[0]), _reasons(d, int(info[1])))]

        bad = sorted(b for share in self._map(job, T) for b in share)
        return F, bad

    def feedback(self, x0: np.ndarray, ff: np.ndarray, ref: np.ndarray, K: np.ndarray,
                 dofs: np.ndarray, lo: np.ndarray, hi: np.ndarray):
        """P closed-loop rollouts: x0 (ns,), ff (P, T, nu), ref (T, ns), K (T, nu, 2c).

        Returns (states (P, T+1, ns), applied (P, T, nu), stats (P, NSTAT) (columns
        ``STATS``), bad): bad lists (step, p, fault, reasons) of the rollouts that failed or
        broke a bound, sorted, with the step, the C file's FAULT_* code (FAULT_MUJOCO_ERROR
        where MuJoCo raised during the step) and the reasons (warning names, the fault's name,
        or MuJoCo's message); their rows after step + 1 (after step, where MuJoCo raised) are
        undefined."""
        P, T, nu = ff.shape
        out = np.empty((P, T + 1, self.layout.nstate))
        applied = np.empty((P, T, nu))
        stats = np.zeros((P, len(STATS)))
        C = np.ascontiguousarray(dofs, dtype=np.int32)
        lay = ctypes.byref(self.layout)
        work = [np.empty(self.lib.dopt_feedback_work(lay, len(C))) for _ in self._datas]
        m = self.model._address

        def job(i, ps):
            w, bad, info = work[i], [], np.zeros(1, np.int32)
            for p in ps:
                d = self._datas[i]
                d.warning.number[:] = 0
                step = self.lib.dopt_feedback(m, d._address, lay, ctypes.byref(self._warnings[i]),
                                              ctypes.byref(self.bounds),
                                              ctypes.byref(self._probes[i]), x0, T, ff[p], ref,
                                              K, C, len(C), lo, hi, out[p], applied[p], w,
                                              stats[p], info)
                if step <= -2:      # MuJoCo raised in step -2 - step: flagged, the rest go on
                    bad.append((-2 - step, int(p), FAULT_MUJOCO_ERROR,
                                [f"MuJoCo error: {self._recover(i)}"]))
                elif step >= 0:
                    bad.append((step, int(p), int(info[0]), _reasons(d, int(info[0]))))
            return bad

        bad = sorted(b for share in self._map(job, P) for b in share)
        return out, applied, stats, bad

    def _recover(self, i: int) -> str:
        """MuJoCo raised inside a call on MjData i: replace it (its stack is left mid-call)
        and return MuJoCo's message. Runs on the thread of that call."""
        message = self.lib.dopt_error_message().decode(errors="replace")
        self._datas[i] = mujoco.MjData(self.model)
        self._warnings[i] = Warnings.of(self._datas[i])
        self._probes[i] = Probe.of(self._datas[i])
        return message


_WARNING_NAMES = [n for n in mujoco.mjtWarning.__members__ if n != "mjNWARNING"]


def warning_names(counts: np.ndarray) -> list[str]:
    """Names of the MuJoCo warnings whose counters (nwarning,) are non-zero, in enum order."""
    return [_WARNING_NAMES[i] for i in np.nonzero(counts)[0]]


def _warnings(d: mujoco.MjData) -> list[str]:
    return warning_names(d.warning.number)


# the FAULT_* codes of the C file, past FAULT_WARNING: the warning MuJoCo's next step would give,
# then the stability bounds (in the order dopt.stability.Scan.update checks them)
_FAULTS = {1: "mjWARN_BADQPOS", 2: "mjWARN_BADQVEL", 3: "non-finite state"}
FAULT_BOUNDS = {4: "speed", 5: "penetration", 6: "strain", 7: "capped_steps", 8: "energy"}
# not a C code: MuJoCo raised an error during the step (the call returned -2 - step)
FAULT_MUJOCO_ERROR = -2


def _reasons(d: mujoco.MjData, fault: int) -> list[str]:
    """Why a step of a kernel call on d failed: MuJoCo's warnings, else the C file's fault
    (for a broken bound, the bound's name)."""
    if fault in FAULT_BOUNDS:
        return [FAULT_BOUNDS[fault]]
    return _warnings(d) or [_FAULTS.get(fault, "non-finite state")]
