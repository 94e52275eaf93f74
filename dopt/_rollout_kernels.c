/* C loops behind dopt.RolloutService, where Python per step or a full mj_step per
 * perturbation would dominate (measured: README, "Why these libraries").
 *
 *   dopt_fd:        reduced finite-difference A^C, B^C of a list of timesteps. As
 *                   mjd_transitionFD restricted to the DoF set C: control nudges skip the
 *                   position and velocity stages, velocity nudges skip the position stage.
 *   dopt_feedback:  one closed-loop rollout u_t = u_ff,t + K_t dx_C(x_t, ref_t), clamped,
 *                   judged after every step by the stability bounds of dopt/stability.py.
 *
 * Both stop at the first step that fails and name it: step t (the step from state row t with
 * control t) fails when MuJoCo warns during it (mj_checkPos / mj_checkVel of its start state,
 * as mj_step and mjd_transitionFD run them, mj_checkAcc, a bad control, ...) or when the state
 * it leaves behind has a |qpos| or |qvel| entry > mjMAXVAL or NaN (which MuJoCo would only
 * reject at the next step) or any non-finite entry.
 *
 * Only MuJoCo's public C API is called, through opaque pointers: no struct field is read, so
 * this file needs no MuJoCo headers and no link step. The symbols resolve against the
 * libmujoco that the mujoco Python package loaded (dopt/kernels.py makes it global first and
 * checks that mj_version matches the version these prototypes were written for). Every call
 * works on the caller's mjData only, so calls on different mjData may run on different threads.
 *
 * MuJoCo errors (mju_error: out of arena memory, ...) would terminate the process from inside
 * a call. dopt_install_log_handler installs a log handler that, on a thread inside a kernel
 * call, longjmps back to the call, which returns -2 - t (t: the timestep or step it was on)
 * with the message in dopt_error_message(); everywhere else it passes every message on to the
 * handler it replaced, so MuJoCo behaves as before for all other code.
 */
#include <math.h>
#include <setjmp.h>
#include <string.h>

typedef double mjtNum;
typedef struct mjModel_ mjModel;
typedef struct mjData_ mjData;

/* prototypes as in mujoco/mujoco.h of MuJoCo 4.0 */
void mj_setState(const mjModel* m, mjData* d, const mjtNum* state, int sig);
void mj_getState(const mjModel* m, const mjData* d, mjtNum* state, int sig);
void mj_fwdPosition(const mjModel* m, mjData* d);
void mj_fwdVelocity(const mjModel* m, mjData* d);
void mj_step2(const mjModel* m, mjData* d);
void mj_step(const mjModel* m, mjData* d);
void mj_checkPos(const mjModel* m, mjData* d);
void mj_checkVel(const mjModel* m, mjData* d);
void mj_integratePos(const mjModel* m, mjtNum* qpos, const mjtNum* qvel, mjtNum dt);
void mj_differentiatePos(const mjModel* m, mjtNum* qvel, mjtNum dt, const mjtNum* qpos1,
                         const mjtNum* qpos2);

/* the head of mjLogMessage (mujoco/mjtype.h, MuJoCo 4.0) and its handler type */
typedef struct {
  int level;              /* mjtLogLevel: mjLOG_ERROR = 3 */
  int topic;
  char subject[1024];
} log_message_t;
typedef void (*log_handler_t)(const log_message_t*);
log_handler_t mju_setLogHandler(log_handler_t handler);

enum { LOG_ERROR = 3 };
static log_handler_t previous_handler = NULL;
static _Thread_local jmp_buf* recovery = NULL;
static _Thread_local char error_message[1024];

static void log_handler(const log_message_t* msg) {
  if (msg->level == LOG_ERROR && recovery) {
    strncpy(error_message, msg->subject, sizeof(error_message) - 1);
    error_message[sizeof(error_message) - 1] = 0;
    longjmp(*recovery, 1);
  }
  previous_handler(msg);
}

/* the calling convention of this file; dopt/kernels.py refuses a build with another one
 * (a stale extension after an update that changed a signature) */
int dopt_abi_version(void) { return 6; }

/* install once, before the first kernel call */
void dopt_install_log_handler(void) {
  if (!previous_handler) previous_handler = mju_setLogHandler(log_handler);
}

/* the message of this thread's last MuJoCo error inside a kernel call */
const char* dopt_error_message(void) { return error_message; }

/* sizes and state-row offsets, filled from Python (dopt.kernels.Layout) */
typedef struct {
  int nq, nv, nu;
  int nstate, sig;        /* state row length and its mjtState bits (mjSTATE_INTEGRATION) */
  int qpos, qvel, ctrl;   /* offsets of qpos, qvel, ctrl in a row */
  int sig_qposvel;        /* mjSTATE_QPOS | mjSTATE_QVEL: [qpos; qvel] */
  int sig_ctrl;           /* mjSTATE_CTRL */
} layout_t;

/* scratch doubles per call */
int dopt_fd_work(const layout_t* L) { return L->nstate + 3 * (L->nq + L->nv) + 2 * L->nv + L->nq; }
int dopt_feedback_work(const layout_t* L, int nc) { return L->nv + 2 * nc; }

/* One step from the state loaded in d. skip 0: full step; 1: the position stage of the
 * loaded state is current, recompute from velocity on; 2: position and velocity stages are
 * current (only ctrl changed). As mj_step for every integrator but RK4 (Python refuses RK4),
 * without its mj_checkPos / mj_checkVel: next_state runs those first. */
static void advance(const mjModel* m, mjData* d, int skip) {
  if (skip < 1) mj_fwdPosition(m, d);
  if (skip < 2) mj_fwdVelocity(m, d);
  mj_step2(m, d);
}

/* why a step failed (dopt/kernels.py names them): MuJoCo warned (read its counters), or the
 * state it left has a bad qpos, a bad qvel (|x| > mjMAXVAL or NaN), another non-finite entry */
enum { FAULT_NONE = -1, FAULT_WARNING = 0, FAULT_QPOS = 1, FAULT_QVEL = 2, FAULT_NONFINITE = 3,
       FAULT_SPEED = 4, FAULT_PENETRATION = 5, FAULT_STRAIN = 6, FAULT_CAPPED = 7,
       FAULT_ENERGY = 8 };
#define MAXVAL 1e10   /* mjMAXVAL of mujoco/mjtype.h: the bound of mj_checkPos/Vel/Acc */

static int bad_value(mjtNum x) { return x != x || x > MAXVAL || x < -MAXVAL; }

/* MuJoCo's warning counters of d: warn[i * stride] is warning i's count (nwarn of them) */
typedef struct {
  const int* number;
  int stride, n;
} warnings_t;

static int warned(const warnings_t* w) {
  for (int i = 0; i < w->n; i++) {
    if (w->number[i * w->stride]) return 1;
  }
  return 0;
}

static int finite(const mjtNum* x, int n) {
  for (int i = 0; i < n; i++) {
    if (!isfinite(x[i])) return 0;
  }
  return 1;
}

/* FAULT_QPOS / FAULT_QVEL if qpos (nq) / qvel (nv) hold a value MuJoCo's checks reject */
static int fault_of(const layout_t* L, const mjtNum* qpos, const mjtNum* qvel) {
  for (int i = 0; i < L->nq; i++) {
    if (bad_value(qpos[i])) return FAULT_QPOS;
  }
  for (int i = 0; i < L->nv; i++) {
    if (bad_value(qvel[i])) return FAULT_QVEL;
  }
  return FAULT_NONE;
}

/* next [qpos; qvel] of the state row `row` after `advance(skip)`: FAULT_NONE, or why the step
 * failed (it is not taken when MuJoCo's checks reject the start state, as mj_step resets) */
static int next_state(const mjModel* m, mjData* d, const layout_t* L, const warnings_t* warn,
                      const mjtNum* row, int skip, mjtNum* out) {
  mj_setState(m, d, row, L->sig);
  mj_checkPos(m, d);
  mj_checkVel(m, d);
  if (warned(warn)) return FAULT_WARNING;
  advance(m, d, skip);
  if (warned(warn)) return FAULT_WARNING;
  mj_getState(m, d, out, L->sig_qposvel);
  return fault_of(L, out, out + L->nq);
}

/* column `col` of M (2c rows, leading dimension ld) = tangent difference (a - b) / h on C */
static void write_column(const mjModel* m, const layout_t* L, const mjtNum* a, const mjtNum* b,
                         mjtNum h, const int* dofs, int nc, mjtNum* M, int ld, int col,
                         mjtNum* dq) {
  mj_differentiatePos(m, dq, h, b, a);
  const mjtNum* va = a + L->nq;
  const mjtNum* vb = b + L->nq;
  for (int r = 0; r < nc; r++) {
    M[r * ld + col] = dq[dofs[r]];
    M[(nc + r) * ld + col] = (va[dofs[r]] - vb[dofs[r]]) / h;
  }
}

static void zero_column(mjtNum* M, int rows, int ld, int col) {
  for (int r = 0; r < rows; r++) M[r * ld + col] = 0;
}

/* Reduced FD derivatives of the state rows states[t] for t in ts[0..nt).
 *   F: (T, 2c, 2c + nu) = [A B], row-major, written at each listed t; the columns of A are
 *   [dq_C | dv_C]. lo, hi: (nu,) control bounds, +-inf where unlimited.
 * Order per timestep: nominal (full step) -> controls (skip 2) -> velocities (skip 1) ->
 * positions (full), so the stages a skipped step reuses are those of the nominal state.
 * Returns -1, or the first listed t one of whose steps failed (see the top of this file; the
 * caller resets the warning counters), with info[0] = that step's perturbation index in the
 * row order of dopt.rollout_batch (0 nominal, then control, velocity, position nudges; the +
 * block before the - block when centred) and info[1] = its FAULT_*; or -2 - t if MuJoCo raised
 * an error at t (d is then unusable). Later timesteps are left undone. */
int dopt_fd(const mjModel* m, mjData* d, const layout_t* L, const warnings_t* warn,
            const mjtNum* states, const int* ts, int nt, const int* dofs, int nc, mjtNum eps,
            int centered, const mjtNum* lo, const mjtNum* hi, mjtNum* F, mjtNum* work,
            int* info) {
  const int nq = L->nq, nv = L->nv, nu = L->nu, n2 = 2 * nc, nx = nq + nv, ld = n2 + nu;
  const int sides = 1 + centered;
  const int vel0 = 1 + sides * nu, pos0 = vel0 + sides * nc;  /* first velocity, position row */
  mjtNum* row = work;               /* perturbed state row (nstate) */
  mjtNum* x0 = row + L->nstate;     /* nominal next [qpos; qvel] */
  mjtNum* xp = x0 + nx;             /* + side */
  mjtNum* xm = xp + nx;             /* - side */
  mjtNum* dq = xm + nx;             /* tangent difference (nv) */
  mjtNum* unit = dq + nv;           /* unit tangent vector (nv) */
  mjtNum* qpos = unit + nv;         /* perturbed qpos (nq) */
  memset(unit, 0, sizeof(mjtNum) * nv);
  jmp_buf env;
  volatile int current = 0;         /* the timestep being differenced, for an error */
  if (setjmp(env)) {
    recovery = NULL;
    return -2 - current;
  }
  recovery = &env;

  int t = 0;
/* one step of timestep t, perturbation row k: on a failure, report it and stop */
#define STEP(state, skip, out, k)                             \
  do {                                                        \
    const int fault = next_state(m, d, L, warn, state, skip, out); \
    if (fault != FAULT_NONE) {                                \
      info[0] = (k);                                          \
      info[1] = fault;                                        \
      recovery = NULL;                                        \
      return t;                                               \
    }                                                         \
  } while (0)

  for (int i = 0; i < nt; i++) {
    t = ts[i];
    current = t;
    const mjtNum* nom = states + (size_t)t * L->nstate;
    mjtNum* At = F + (size_t)t * n2 * ld;
    mjtNum* Bt = At + n2;
    STEP(nom, 0, x0, 0);
    memcpy(row, nom, sizeof(mjtNum) * L->nstate);

    /* controls: one-sided inward differences at ctrlrange limits, as mjd_transitionFD */
    for (int j = 0; j < nu; j++) {
      const mjtNum c = nom[L->ctrl + j];
      const int fwd = c >= lo[j] && c + eps <= hi[j];
      const int back = (centered || !fwd) && c - eps >= lo[j] && c <= hi[j];
      if (fwd) {
        row[L->ctrl + j] = c + eps;
        STEP(row, 2, xp, 1 + j);
      }
      if (back) {
        row[L->ctrl + j] = c - eps;
        STEP(row, 2, xm, 1 + (centered ? nu : 0) + j);
      }
      row[L->ctrl + j] = c;
      if (fwd && back) write_column(m, L, xp, xm, 2 * eps, dofs, nc, Bt, ld, j, dq);
      else if (fwd) write_column(m, L, xp, x0, eps, dofs, nc, Bt, ld, j, dq);
      else if (back) write_column(m, L, x0, xm, eps, dofs, nc, Bt, ld, j, dq);
      else zero_column(Bt, n2, ld, j);
    }
    /* velocities */
    for (int k = 0; k < nc; k++) {
      const int v = L->qvel + dofs[k];
      row[v] = nom[v] + eps;
      STEP(row, 1, xp, vel0 + k);
      if (centered) {
        row[v] = nom[v] - eps;
        STEP(row, 1, xm, vel0 + nc + k);
        write_column(m, L, xp, xm, 2 * eps, dofs, nc, At, ld, nc + k, dq);
      } else {
        write_column(m, L, xp, x0, eps, dofs, nc, At, ld, nc + k, dq);
      }
      row[v] = nom[v];
    }
    /* positions, in the tangent space (quaternions through mj_integratePos) */
    for (int k = 0; k < nc; k++) {
      unit[dofs[k]] = 1;
      for (int side = 0; side < 1 + centered; side++) {
        memcpy(qpos, nom + L->qpos, sizeof(mjtNum) * nq);
        mj_integratePos(m, qpos, unit, side ? -eps : eps);
        memcpy(row + L->qpos, qpos, sizeof(mjtNum) * nq);
        STEP(row, 0, side ? xm : xp, pos0 + side * nc + k);
      }
      unit[dofs[k]] = 0;
      memcpy(row + L->qpos, nom + L->qpos, sizeof(mjtNum) * nq);
      if (centered) write_column(m, L, xp, xm, 2 * eps, dofs, nc, At, ld, k, dq);
      else write_column(m, L, xp, x0, eps, dofs, nc, At, ld, k, dq);
    }
  }
#undef STEP
  recovery = NULL;
  return -1;
}

/* The stability bounds of one model (dopt.stability.Monitor fills it): the same expressions,
 * in the same order, as Monitor.speed / penetration / strain / capped / free / energy_gain. */
typedef struct {
  const int* groups; int ngroup;        /* (ngroup, 3) qvel indices of linear DoFs, -1 pad */
  const mjtNum* planes; int nplane;     /* (nplane, 4): unit normal, offset n.p */
  const mjtNum* radius; int nvert;      /* (nvert,) flex vertex radii */
  const mjtNum* length0; int nedge;     /* (nedge,) flex edge rest lengths (<= 0: skipped) */
  int iteration_cap, max_capped;        /* max_capped < 0: capped steps are only counted */
  mjtNum max_speed, max_penetration, max_strain;
  const int* edge_grasps; int grasp_width;  /* (nedge, grasp_width) equality ids at each
                                               edge's vertices, -1 pad: skipped while active */
  int energy_judged;                    /* 0: the energy bound is not set */
  mjtNum max_energy, energy_mass;       /* J/kg; kg of the judged bodies */
  const int* window_eqs; int nwindow;   /* equalities whose activity ends a free window */
  const int* working_act; int nworking; /* actuators whose force ends a free window */
  const int* spin_dofs;                 /* (nspin, spin_width, 3) qvel indices of the angular
                                           velocity of each hinge / ball joint of a body, -1 pad */
  const mjtNum* spin_radius;            /* (nspin, spin_width) their r_j (0 in padding) */
  int nspin, spin_width;                /* bodies turned by hinge / ball joints, joints per body */
} bounds_t;

/* one MjData's fields, read in place: flexvert_xpos (nvert, 3), flexedge_length (nedge),
 * solver_niter (nisland) */
typedef struct {
  const mjtNum* vert_xpos;
  const mjtNum* edge_length;
  const int* niter;
  int nisland;
  const unsigned char* eq_active;      /* (neq,) mjtByte */
  const mjtNum* energy;                 /* (2,) potential, kinetic of the step's start state */
  const mjtNum* actuator_force;         /* (nu,) */
} probe_t;

/* running extremes of one rollout: max speed, penetration, strain, capped steps, energy gain;
 * the violated bound's value and index; the energy window in progress (its lowest energy,
 * whether the last step was free) */
enum { STAT_SPEED, STAT_PENETRATION, STAT_STRAIN, STAT_CAPPED, STAT_ENERGY, STAT_VALUE,
       STAT_INDEX, STAT_LOW, STAT_FREE, NSTAT };

/* Judge the step just taken (qvel of the new state, positions of the step's start state):
 * FAULT_NONE or the first broken bound, with its value and index in stats. */
static int judge(const bounds_t* B, const probe_t* p, const mjtNum* qvel, mjtNum* stats) {
  mjtNum speed = -INFINITY, pen = -INFINITY, strain = -INFINITY;
  int si = 0, pi = 0, ei = 0;
  for (int g = 0; g < B->ngroup; g++) {
    mjtNum v[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) {
      const int i = B->groups[3 * g + k];
      if (i >= 0) v[k] = qvel[i];
    }
    const mjtNum s = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (s > speed) { speed = s; si = g; }
  }
  /* farthest geometry of each body turned by hinge / ball joints: sum_j |w_j| r_j */
  for (int g = 0; g < B->nspin; g++) {
    mjtNum s = 0;
    for (int k = 0; k < B->spin_width; k++) {
      const int slot = g * B->spin_width + k;
      mjtNum w[3] = {0, 0, 0};
      for (int c = 0; c < 3; c++) {
        const int i = B->spin_dofs[3 * slot + c];
        if (i >= 0) w[c] = qvel[i];
      }
      s += sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * B->spin_radius[slot];
    }
    if (s > speed) { speed = s; si = B->ngroup + g; }
  }
  if (B->nplane) {
    for (int i = 0; i < B->nvert; i++) {
      const mjtNum* x = p->vert_xpos + 3 * i;
      mjtNum depth = -INFINITY;
      for (int k = 0; k < B->nplane; k++) {
        const mjtNum* n = B->planes + 4 * k;
        const mjtNum dk = B->radius[i] - ((x[0] * n[0] + x[1] * n[1] + x[2] * n[2]) - n[3]);
        if (dk > depth) depth = dk;
      }
      if (depth > pen) { pen = depth; pi = i; }
    }
  }
  for (int e = 0; e < B->nedge; e++) {
    if (B->length0[e] <= 0) continue;
    int held = 0;
    for (int j = 0; j < B->grasp_width; j++) {
      const int q = B->edge_grasps[e * B->grasp_width + j];
      if (q >= 0 && p->eq_active[q]) held = 1;
    }
    if (held) continue;
    const mjtNum r = fabs(p->edge_length[e] / B->length0[e] - 1.0);
    if (r > strain) { strain = r; ei = e; }
  }
  int capped = 0;
  for (int i = 0; i < p->nisland; i++) {
    if (p->niter[i] >= B->iteration_cap) capped = 1;
  }
  mjtNum gain = 0;
  if (B->energy_judged) {
    const mjtNum e = p->energy[0] + p->energy[1];
    const int was_free = stats[STAT_FREE] != 0;
    if (was_free) {
      gain = (e - stats[STAT_LOW]) / B->energy_mass;
      if (e < stats[STAT_LOW]) stats[STAT_LOW] = e;
    }
    int free = 1;
    for (int i = 0; i < B->nwindow; i++) {
      if (p->eq_active[B->window_eqs[i]]) free = 0;
    }
    for (int i = 0; i < B->nworking; i++) {
      if (!(p->actuator_force[B->working_act[i]] == 0)) free = 0;
    }
    if (free && !was_free) stats[STAT_LOW] = e;
    stats[STAT_FREE] = free;
  }
  if (B->ngroup + B->nspin == 0) speed = 0;
  if (B->nplane == 0 || B->nvert == 0) pen = 0;
  if (strain == -INFINITY) strain = 0;
  stats[STAT_CAPPED] += capped;
  if (speed > stats[STAT_SPEED]) stats[STAT_SPEED] = speed;
  if (pen > stats[STAT_PENETRATION]) stats[STAT_PENETRATION] = pen;
  if (strain > stats[STAT_STRAIN]) stats[STAT_STRAIN] = strain;
  if (gain > stats[STAT_ENERGY]) stats[STAT_ENERGY] = gain;
  if (speed > B->max_speed) {
    stats[STAT_VALUE] = speed; stats[STAT_INDEX] = si; return FAULT_SPEED;
  }
  if (pen > B->max_penetration) {
    stats[STAT_VALUE] = pen; stats[STAT_INDEX] = pi; return FAULT_PENETRATION;
  }
  if (strain > B->max_strain) {
    stats[STAT_VALUE] = strain; stats[STAT_INDEX] = ei; return FAULT_STRAIN;
  }
  if (B->max_capped >= 0 && stats[STAT_CAPPED] > B->max_capped) {
    stats[STAT_VALUE] = stats[STAT_CAPPED]; stats[STAT_INDEX] = 0; return FAULT_CAPPED;
  }
  if (B->energy_judged && gain > B->max_energy) {
    stats[STAT_VALUE] = gain; stats[STAT_INDEX] = 0; return FAULT_ENERGY;
  }
  return FAULT_NONE;
}

/* One closed-loop rollout of T steps from the state row x0:
 *   u_t = clamp(ff_t + K_t [q_C (-) ref_q_C ; v_C - ref_v_C], lo, hi)
 * ff: (T, nu); ref: (T, nstate); K: (T, nu, 2c); out: (T+1, nstate), row t holding u_t;
 * applied: (T, nu). After each step that MuJoCo accepted, the bounds B judge it (probe: d's
 * fields); stats (NSTAT) collects the extremes. Returns -1, or the first step that failed or
 * broke a bound (the rollout stops there) with info[0] its FAULT_*, or -2 - t if MuJoCo raised
 * an error in step t (d is then unusable). */
int dopt_feedback(const mjModel* m, mjData* d, const layout_t* L, const warnings_t* warn,
                  const bounds_t* B, const probe_t* probe, const mjtNum* x0, int T,
                  const mjtNum* ff, const mjtNum* ref, const mjtNum* K, const int* dofs, int nc,
                  const mjtNum* lo, const mjtNum* hi, mjtNum* out, mjtNum* applied,
                  mjtNum* work, mjtNum* stats, int* info) {
  const int nu = L->nu, n2 = 2 * nc;
  mjtNum* dq = work;          /* nv */
  mjtNum* dx = dq + L->nv;    /* 2c */
  jmp_buf env;
  volatile int current = 0;
  if (setjmp(env)) {
    recovery = NULL;
    return -2 - current;
  }
  recovery = &env;
  for (int i = 0; i < NSTAT; i++) stats[i] = 0;
  mj_setState(m, d, x0, L->sig);
  mj_getState(m, d, out, L->sig);
  for (int t = 0; t < T; t++) {
    current = t;
    mjtNum* row = out + (size_t)t * L->nstate;
    const mjtNum* r = ref + (size_t)t * L->nstate;
    mj_differentiatePos(m, dq, 1, r + L->qpos, row + L->qpos);
    for (int k = 0; k < nc; k++) {
      dx[k] = dq[dofs[k]];
      dx[nc + k] = row[L->qvel + dofs[k]] - r[L->qvel + dofs[k]];
    }
    const mjtNum* Kt = K + (size_t)t * nu * n2;
    for (int j = 0; j < nu; j++) {
      mjtNum u = ff[(size_t)t * nu + j];
      for (int k = 0; k < n2; k++) u += Kt[j * n2 + k] * dx[k];
      if (u < lo[j]) u = lo[j];
      if (u > hi[j]) u = hi[j];
      applied[(size_t)t * nu + j] = u;
      row[L->ctrl + j] = u;
    }
    mj_setState(m, d, row + L->ctrl, L->sig_ctrl);
    mj_step(m, d);
    mjtNum* next = row + L->nstate;
    mj_getState(m, d, next, L->sig);
    int fault = warned(warn) ? FAULT_WARNING : fault_of(L, next + L->qpos, next + L->qvel);
    if (fault == FAULT_NONE && !finite(next, L->nstate)) fault = FAULT_NONFINITE;
    if (fault == FAULT_NONE) fault = judge(B, probe, next + L->qvel, stats);
    if (fault != FAULT_NONE) {
      info[0] = fault;
      recovery = NULL;
      return t;
    }
  }
  recovery = NULL;
  return -1;
}
