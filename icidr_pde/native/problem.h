/* What every compiled problem of the native engine is to the CVODE driver (cvode_driver.c): the
   state of 3 n values (n points of a 1-D cell, n cells of a 2-D one), where the values of each
   point sit in it, the law's parameters and the valid range of phi, CVODE's objects, and the
   cell's own part: its data and the functions that give its rates, its Jacobian (for the
   kernels' timings) and set up CVODE's linear solver. A cell's problem file (its folder's
   problem.c, placed between this header and the driver) allocates a problem with problem_new
   and fills in its part. */

#include <stdlib.h>
#include <string.h>
#include <stdio.h>
#include <time.h>

#define EXPORT __attribute__((visibility("default")))

typedef struct Native Native;

struct Native {
    int n;                /* points (1-D) or cells (2-D): the state vector has 3 n values */
    int point_step;       /* value k of point i at y[i * point_step + k * field_step] */
    int field_step;
    double *params;
    int n_params;
    double lo, hi;
    double *y_good;
    double t_good;
    long max_steps;       /* CVODE's steps towards one output before the run fails */
    long pause_steps;     /* the driver returns to its caller after this many in one call */
    long steps_taken;     /* steps towards the current output in the calls before this one */
    int krylov;           /* the linear solver is GMRES: icidr_krylov_counts counts it */
    long n_jac;           /* krylov: Jacobians the problem evaluated for its preconditioner */
    void *cvode;
    SUNContext ctx;
    N_Vector y;
    SUNMatrix A;
    SUNLinearSolver LS;
    char message[1024];
    /* the cell's part */
    void *data;
    void (*rates)(Native *p, const double *y, double *out);
    void (*jacobian)(Native *p, const double *y, double *J);  /* NULL: none (CVODE's products J v) */
    size_t jacobian_size;  /* doubles of J */
    /* CVODE's linear solver on the created and initialised p->cvode; 0, or -1 with `error` set */
    int (*linear_solver)(Native *p, const double *y0, char *error, int error_len);
    void (*free_data)(void *data);
};

/* a problem of n points with the law's parameters, the valid range of phi and the layout of the
   state; NULL where memory runs out */
static Native *problem_new(int n, int point_step, int field_step, const double *params, int n_params, double lo,
                           double hi);
EXPORT void icidr_free(Native *p);

/* a call of CVODE's C API in a cell's linear_solver: -1 with `error` set where it fails */
#define SETUP(call) do { if ((call) < 0) { snprintf(error, error_len, "%s failed", #call); return -1; } } while (0)
