/* CVODE driver of the native engine: any cell's compiled problem (problem.h) integrated by
   SUNDIALS CVODE without a Python callback.

   The same CVODE set-up as icidr_pde.engines.sundae.CvodeEngine (through scikit-sundae) on
   the same problem: BDF up to order 5, scalar tolerances, the problem's linear solver (each
   cell's problem.c sets it up: the band or dense LU with the analytic Jacobian, or GMRES), at
   most 3 Newton iterations and 10 convergence failures a step, 1e6 steps, the minimum step the
   caller gives (a fraction of the fastest time scale 1/rho(J(y0)), icidr_pde.time_scale), and the
   validity root function (min phi - lo, hi - max phi, direction -1, terminal). Output at
   requested times by CV_NORMAL calls (CVODE's interpolant): no output time after the first
   changes CVODE's steps. After `pause_steps` steps in one call the driver returns to the caller,
   between two outputs or inside one stretch (CVODE's mxstep, CV_TOO_MUCH_WORK, then not counted
   as a failure), so that a signal (Ctrl-C, SIGTERM) is seen by Python within them; the next call
   goes on with the same steps.
   Placed after problem.h and the cell's problem.c (icidr_pde.native.build); sundials_api.h
   declares the part of the SUNDIALS C API used here. */

/* where value k of point i sits in the state vector (problem.h) */
#define VALUE_AT(p, i, k) ((i) * (p)->point_step + (k) * (p)->field_step)
#define PHI_AT(p, i) VALUE_AT(p, i, 0)
#define W_AT(p, i) VALUE_AT(p, i, 2)

static int rhs_fn(sunrealtype t, N_Vector y, N_Vector ydot, void *user_data)
{
    Native *p = (Native *)user_data;
    p->rates(p, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot));
    return 0;
}

static int root_fn(sunrealtype t, N_Vector y, sunrealtype *gout, void *user_data)
{
    Native *p = (Native *)user_data;
    const double *v = N_VGetArrayPointer(y);
    double low = INFINITY, high = -INFINITY;
    for (int i = 0; i < p->n; i++) {
        double phi = v[PHI_AT(p, i)];
        low = phi < low ? phi : low;   /* as min()/max(): a NaN never wins */
        high = phi > high ? phi : high;
    }
    gout[0] = low - p->lo;
    gout[1] = p->hi - high;
    return 0;
}

static void error_handler(int line, const char *func, const char *file, const char *msg,
                          SUNErrCode err_code, void *err_user_data, SUNContext sunctx)
{
    Native *p = (Native *)err_user_data;
    snprintf(p->message, sizeof p->message, "%s", msg ? msg : "");
}

/* what every problem holds: n points, the law's parameters, the valid range of phi, the layout
   of its state and the last good state; NULL where memory runs out */
static Native *problem_new(int n, int point_step, int field_step, const double *params, int n_params, double lo,
                           double hi)
{
    Native *p = calloc(1, sizeof(Native));
    if (!p)
        return NULL;
    p->n = n;
    p->point_step = point_step;
    p->field_step = field_step;
    p->lo = lo;
    p->hi = hi;
    p->params = malloc(sizeof(double) * (n_params > 0 ? n_params : 1));
    p->y_good = malloc(sizeof(double) * 3 * (size_t)n);
    if (!p->params || !p->y_good) {
        icidr_free(p);
        return NULL;
    }
    memcpy(p->params, params, sizeof(double) * n_params);
    p->n_params = n_params;
    return p;
}

EXPORT void icidr_rates(Native *p, const double *y, double *out)
{
    p->rates(p, y, out);
}

static double seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* best of `reps` timings (seconds) of one right-hand side (out[0]) and one Jacobian (out[1], 0 where
   the problem has none); the kernels' own cost, for the benchmark's roofline */
EXPORT void icidr_kernel_times(Native *p, const double *y, int reps, double *out)
{
    int neq = 3 * p->n;
    double *f = malloc(sizeof(double) * neq), *J = malloc(sizeof(double) * (p->jacobian_size ? p->jacobian_size : 1));
    out[0] = out[1] = INFINITY;
    for (int r = 0; r < reps; r++) {
        double start = seconds();
        p->rates(p, y, f);
        double mid = seconds();
        if (p->jacobian)
            p->jacobian(p, y, J);
        else
            out[1] = 0.0;  /* no Jacobian: CVODE's products J v */
        double end = seconds();
        out[0] = mid - start < out[0] ? mid - start : out[0];
        out[1] = end - mid < out[1] ? end - mid : out[1];
    }
    free(f);
    free(J);
}

/* OpenBLAS threads of the dense LU and the BLAS products (returns 0 where the build has no BLAS) */
EXPORT int icidr_blas_threads(int threads)
{
#ifdef ICIDR_BLAS
    openblas_set_num_threads(threads);
    return 1;
#else
    return 0;
#endif
}

/* M(phi) of the law at m points (for chi of (A18)) */
EXPORT void icidr_law_M(Native *p, int m, const double *phi, double *out)
{
    for (int k = 0; k < m; k++)
        out[k] = law_M(phi[k], p->params);
}

#define CHECK(call) do { if ((call) < 0) { snprintf(error, error_len, "%s failed", #call); goto fail; } } while (0)

/* Start CVODE at (t0, y0) on the problem `p`; 0 on success, else -1 with `error` set. */
EXPORT int icidr_cvode_start(Native *p, double t0, const double *y0, double rtol, double atol,
                             double min_step, double max_step, long max_num_steps, long pause_steps,
                             double first_step, int max_order, char *error, int error_len)
{
    int neq = 3 * p->n;
    int direction[2] = {-1, -1};
    if (SUNContext_Create(SUN_COMM_NULL, &p->ctx) < 0) {
        snprintf(error, error_len, "SUNContext_Create failed");
        return -1;
    }
    SUNContext_ClearErrHandlers(p->ctx);
    SUNContext_PushErrHandler(p->ctx, error_handler, p);
    p->y = N_VNew_Serial(neq, p->ctx);
    if (!p->y) {
        snprintf(error, error_len, "N_VNew_Serial failed");
        goto fail;
    }
    memcpy(N_VGetArrayPointer(p->y), y0, sizeof(double) * neq);
    memcpy(p->y_good, y0, sizeof(double) * neq);
    p->t_good = t0;
    p->cvode = CVodeCreate(CV_BDF, p->ctx);
    if (!p->cvode) {
        snprintf(error, error_len, "CVodeCreate failed");
        goto fail;
    }
    CHECK(CVodeSetUserData(p->cvode, p));
    CHECK(CVodeInit(p->cvode, rhs_fn, t0, p->y));
    CHECK(CVodeSStolerances(p->cvode, rtol, atol));
    if (p->linear_solver(p, y0, error, error_len) < 0)
        goto fail;
    CHECK(CVodeSetMaxNonlinIters(p->cvode, 3));
    CHECK(CVodeSetMaxConvFails(p->cvode, 10));
    CHECK(CVodeRootInit(p->cvode, 2, root_fn));
    CHECK(CVodeSetRootDirection(p->cvode, direction));
    CHECK(CVodeSetInitStep(p->cvode, first_step));
    CHECK(CVodeSetMinStep(p->cvode, min_step));
    CHECK(CVodeSetMaxStep(p->cvode, max_step));
    CHECK(CVodeSetMaxOrd(p->cvode, max_order));
    p->max_steps = max_num_steps;
    p->pause_steps = pause_steps < max_num_steps ? pause_steps : max_num_steps;
    p->steps_taken = 0;
    CHECK(CVodeSetMaxNumSteps(p->cvode, p->pause_steps));
    /* no "t + h = t" warnings on stdout (they would break --json /dev/stdout): a step that small
       ends the run at the minimum step, whose reason the Result reports */
    CHECK(CVodeSetMaxHnilWarns(p->cvode, -1));
    return 0;
fail:
    if (p->message[0]) {
        int used = (int)strlen(error);
        snprintf(error + used, error_len - used, ": %s", p->message);
    }
    return -1;
}

static int inside(const Native *p, const double *v)
{
    for (int k = 0; k < 3 * p->n; k++)
        if (!isfinite(v[k]))
            return 0;
    for (int i = 0; i < p->n; i++)
        if (!(p->lo < v[PHI_AT(p, i)] && v[PHI_AT(p, i)] < p->hi))
            return 0;
    return 1;
}

/* Advance through the output times t_out[0..n_out-1] (increasing, after the current time).
   At each: max_w[k] = max |w| over the cells, and the state into states + store[k] * 3n where
   store[k] >= 0. Returns 0 when all are done, else the output index k where it stopped
   (*n_done = k) and *status: 1 a root (phi reached the end of its range), 2 CVODE failed
   (flag in *flag, message via icidr_cvode_message), 3 the state at t_out[k] is invalid, 4 paused
   after pause_steps steps in this call, before t_out[k] (call again with the outputs from k on).
   The last valid state and its time are kept (icidr_cvode_last_good). */
EXPORT int icidr_cvode_advance(Native *p, int n_out, const double *t_out, const int *store, double *max_w,
                               double *states, int *n_done, int *status, int *flag)
{
    int neq = 3 * p->n;
    double *y = N_VGetArrayPointer(p->y);
    long steps_at_call = 0;
    CVodeGetNumSteps(p->cvode, &steps_at_call);
    *status = 0;
    *flag = 0;
    for (int k = 0; k < n_out; k++) {
        double t_ret = p->t_good;
        p->message[0] = 0;
        /* at most pause_steps steps in this call; the last stretch before the step limit is
           shorter, so that the run fails at max_steps exactly */
        long now = 0;
        CVodeGetNumSteps(p->cvode, &now);
        long stretch = p->pause_steps - (now - steps_at_call);
        if (stretch <= 0) {
            *n_done = k;
            *status = 4;
            return 1;
        }
        if (stretch > p->max_steps - p->steps_taken)
            stretch = p->max_steps - p->steps_taken;
        CVodeSetMaxNumSteps(p->cvode, stretch);
        int f = CVode(p->cvode, t_out[k], p->y, &t_ret, CV_NORMAL);
        if (f == CV_TOO_MUCH_WORK && p->steps_taken + stretch < p->max_steps) {
            p->steps_taken += stretch;
            *n_done = k;
            *status = 4;
            return 1;
        }
        p->steps_taken = 0;
        *flag = f;
        int finite = 1;
        for (int q = 0; q < neq; q++)
            finite &= isfinite(y[q]) != 0;
        if (f < 0) {
            if (finite && t_ret > p->t_good) {
                p->t_good = t_ret;
                memcpy(p->y_good, y, sizeof(double) * neq);
            }
            *n_done = k;
            *status = 2;
            return 1;
        }
        p->t_good = t_ret;
        memcpy(p->y_good, y, sizeof(double) * neq);
        if (f == CV_ROOT_RETURN) {
            *n_done = k;
            *status = 1;
            return 1;
        }
        if (!inside(p, y)) {
            *n_done = k;
            *status = 3;
            return 1;
        }
        double m = 0.0;
        for (int i = 0; i < p->n; i++) {
            double a = fabs(y[W_AT(p, i)]);
            m = a > m ? a : m;
        }
        max_w[k] = m;
        if (store[k] >= 0)
            memcpy(states + (size_t)store[k] * neq, y, sizeof(double) * neq);
    }
    *n_done = n_out;
    return 0;
}

EXPORT double icidr_cvode_last_good(Native *p, double *y)
{
    memcpy(y, p->y_good, sizeof(double) * 3 * p->n);
    return p->t_good;
}

/* CVODE's last accepted step, at or past the last output: its time (returned) and its state into y,
   the interpolant of order 0 at that time (CVodeGetDky: the Nordsieck array's first column). The
   last output's (icidr_cvode_last_good) before the first step (no step size, no interpolant) or
   where CVODE refuses. */
EXPORT double icidr_cvode_last_step(Native *p, double *y)
{
    int neq = 3 * p->n;
    long steps = 0;
    sunrealtype t = p->t_good;
    N_Vector v = NULL;
    if (CVodeGetNumSteps(p->cvode, &steps) == CV_SUCCESS && steps > 0
        && CVodeGetCurrentTime(p->cvode, &t) == CV_SUCCESS && (v = N_VNew_Serial(neq, p->ctx)) != NULL
        && CVodeGetDky(p->cvode, t, 0, v) == CV_SUCCESS) {
        memcpy(y, N_VGetArrayPointer(v), sizeof(double) * neq);
        N_VDestroy(v);
        return t;
    }
    if (v != NULL)
        N_VDestroy(v);
    return icidr_cvode_last_good(p, y);
}

EXPORT void icidr_cvode_message(Native *p, int flag, char *out, int out_len)
{
    char *name = CVodeGetReturnFlagName(flag);
    snprintf(out, out_len, "%s%s%s", name ? name : "CVODE error", p->message[0] ? "; SUNDIALS: " : "", p->message);
    free(name);
}

/* steps, RHS evaluations (CVODE's), Jacobians, LU set-ups, error-test
   failures, Newton iterations, Newton convergence failures */
EXPORT void icidr_cvode_counts(Native *p, long *out)
{
    long v = 0;
    memset(out, 0, 7 * sizeof(long));
    if (!p->cvode)
        return;
    CVodeGetNumSteps(p->cvode, &v); out[0] = v;
    CVodeGetNumRhsEvals(p->cvode, &v); out[1] = v;
    CVodeGetNumJacEvals(p->cvode, &v); out[2] = v;
    CVodeGetNumLinSolvSetups(p->cvode, &v); out[3] = v;
    CVodeGetNumErrTestFails(p->cvode, &v); out[4] = v;
    CVodeGetNumNonlinSolvIters(p->cvode, &v); out[5] = v;
    CVodeGetNumNonlinSolvConvFails(p->cvode, &v); out[6] = v;
    if (p->krylov)
        out[2] = p->n_jac;
}

/* krylov: GMRES iterations, their convergence failures, preconditioner set-ups (LUs) and
   solves, products J v, right-hand sides of those products (not in icidr_cvode_counts' count) */
EXPORT void icidr_krylov_counts(Native *p, long *out)
{
    long v = 0;
    memset(out, 0, 6 * sizeof(long));
    if (!p->cvode || !p->krylov)
        return;
    CVodeGetNumLinIters(p->cvode, &v); out[0] = v;
    CVodeGetNumLinConvFails(p->cvode, &v); out[1] = v;
    CVodeGetNumPrecEvals(p->cvode, &v); out[2] = v;
    CVodeGetNumPrecSolves(p->cvode, &v); out[3] = v;
    CVodeGetNumJtimesEvals(p->cvode, &v); out[4] = v;
    CVodeGetNumLinRhsEvals(p->cvode, &v); out[5] = v;
}

EXPORT void icidr_free(Native *p)
{
    if (!p)
        return;
    if (p->cvode)
        CVodeFree(&p->cvode);
    if (p->LS)
        SUNLinSolFree(p->LS);
    if (p->A)
        SUNMatDestroy(p->A);
    if (p->y)
        N_VDestroy(p->y);
    if (p->ctx)
        SUNContext_Free(&p->ctx);
    if (p->free_data)
        p->free_data(p->data);
    free(p->params); free(p->y_good);
    free(p);
}
