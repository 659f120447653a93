// Error trampoline for MuJoCo 2.2: a fatal mju_error inside a guarded call long-jumps back to that call, which
// returns 1 with MuJoCo's message, instead of MuJoCo's default handler (print, wait on stdin, exit(1)).
//
// The jump target and the message are thread-local, so an error on one thread never disturbs another. MuJoCo
// calls its per-thread hook first, then the process-global mju_user_error; we install the global one once (it
// consults our thread-local state) because the per-thread hook is a private, unversioned symbol. Only C frames
// lie between sigsetjmp and siglongjmp: the Rust callers sit outside the guarded region.

#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

typedef void (*mjs_log_cb)(const char*);

static mjs_log_cb g_warning_cb = NULL;
static _Thread_local sigjmp_buf* tls_jump = NULL;
static _Thread_local char tls_message[1024];

static void mjs_error_handler(const char* msg) {
  snprintf(tls_message, sizeof tls_message, "%s", msg ? msg : "(no message)");
  if (tls_jump) {
    siglongjmp(*tls_jump, 1);
  }
  // MuJoCo's handlers must not return. Every entry point that can raise is guarded by the Rust layer, so reaching
  // this is a bug in mujoco-sys; fail loudly rather than corrupt memory.
  fprintf(stderr, "mujoco-sys: MuJoCo error outside a guarded call (bug): %s\n", tls_message);
  abort();
}

static void mjs_warning_handler(const char* msg) {
  if (g_warning_cb) {
    g_warning_cb(msg ? msg : "(no message)");
  }
}

void mjs_install_handlers(mjs_log_cb warning_cb) {
  g_warning_cb = warning_cb;
  mju_user_error = mjs_error_handler;
  mju_user_warning = mjs_warning_handler;
}

static void copy_error(char* err, int errlen) {
  if (err && errlen > 0) {
    snprintf(err, (size_t)errlen, "%s", tls_message);
  }
}

// GUARDED(body): run body with the thread's jump target set; 0 on success, 1 (and err filled) on mju_error.
#define GUARDED(body)                               \
  sigjmp_buf jump;                                  \
  sigjmp_buf* volatile previous = tls_jump;         \
  if (sigsetjmp(jump, 0)) {                         \
    tls_jump = previous;                            \
    copy_error(err, errlen);                        \
    return 1;                                       \
  }                                                 \
  tls_jump = &jump;                                 \
  body;                                             \
  tls_jump = previous;                              \
  return 0;

int mjs_step(const mjModel* m, mjData* d, char* err, int errlen) { GUARDED(mj_step(m, d)) }
int mjs_step1(const mjModel* m, mjData* d, char* err, int errlen) { GUARDED(mj_step1(m, d)) }
int mjs_step2(const mjModel* m, mjData* d, char* err, int errlen) { GUARDED(mj_step2(m, d)) }
int mjs_forward(const mjModel* m, mjData* d, char* err, int errlen) { GUARDED(mj_forward(m, d)) }
int mjs_reset_data(const mjModel* m, mjData* d, char* err, int errlen) { GUARDED(mj_resetData(m, d)) }
int mjs_reset_data_keyframe(const mjModel* m, mjData* d, int key, char* err, int errlen) {
  GUARDED(mj_resetDataKeyframe(m, d, key))
}
int mjs_set_const(mjModel* m, mjData* d, char* err, int errlen) { GUARDED(mj_setConst(m, d)) }

int mjs_make_data(const mjModel* m, mjData** out, char* err, int errlen) { GUARDED(*out = mj_makeData(m)) }
int mjs_copy_data(mjData** out, const mjModel* m, const mjData* src, char* err, int errlen) {
  GUARDED(*out = mj_copyData(NULL, m, src))
}
int mjs_copy_model(mjModel** out, const mjModel* src, char* err, int errlen) {
  GUARDED(*out = mj_copyModel(NULL, src))
}

// Loading reports parse/compile errors through `err` itself; the guard catches the rarer mju_error path.
int mjs_load_xml(const char* filename, const mjVFS* vfs, mjModel** out, char* err, int errlen) {
  GUARDED(*out = mj_loadXML(filename, vfs, err, errlen))
}

// The MJCF of the last model loaded from XML with m's values copied back (mj_saveLastXML); *ok is its result.
int mjs_save_last_xml(const char* filename, const mjModel* m, int* ok, char* err, int errlen) {
  GUARDED(*ok = mj_saveLastXML(filename, m, err, errlen))
}

// Positions and velocities of every body, geom and site for the current qpos/qvel, without forces or contacts
// (what a robot's own kinematics computes from its encoders).
int mjs_kinematics(const mjModel* m, mjData* d, char* err, int errlen) {
  GUARDED(mj_kinematics(m, d); mj_comPos(m, d); mj_comVel(m, d))
}

// Positions, the constraint set and its Jacobian for the current qpos (no velocities, forces or integration):
// what loop-closure solving needs.
int mjs_fwd_position(const mjModel* m, mjData* d, char* err, int errlen) { GUARDED(mj_fwdPosition(m, d)) }

// Inverse dynamics: the generalised forces (qfrc_inverse) that give the current qacc at the current state.
int mjs_inverse(const mjModel* m, mjData* d, char* err, int errlen) { GUARDED(mj_inverse(m, d)) }

// Rendering calls that raise mju_error when no usable OpenGL context is current.
int mjs_make_scene(const mjModel* m, mjvScene* scn, int maxgeom, char* err, int errlen) {
  GUARDED(mjv_makeScene(m, scn, maxgeom))
}
int mjs_make_context(const mjModel* m, mjrContext* con, int fontscale, char* err, int errlen) {
  GUARDED(mjr_makeContext(m, con, fontscale))
}
int mjs_render(mjrRect viewport, mjvScene* scn, const mjrContext* con, char* err, int errlen) {
  GUARDED(mjr_render(viewport, scn, con))
}
