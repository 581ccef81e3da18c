/* The part of the SUNDIALS 7 C API the native driver calls, declared as in SUNDIALS'
   headers (cvode/cvode.h, cvode/cvode_ls.h, sundials/sundials_context.h, nvector_serial.h,
   sunmatrix_band.h, sunlinsol_band.h, sunmatrix_dense.h, sunlinsol_dense.h,
   sunlinsol_lapackdense.h, sunlinsol_spgmr.h; scikit-sundae ships the libraries but not these
   headers). SUNINDEXTYPE is the index type of that build (scikit-sundae's c_config.pxi),
   set by the build. */

#include <math.h>

#ifndef SUNINDEXTYPE
#define SUNINDEXTYPE int
#endif

typedef double sunrealtype;
typedef SUNINDEXTYPE sunindextype;
typedef int SUNErrCode;
typedef int SUNComm;
#define SUN_COMM_NULL 0

typedef struct _SUNContext *SUNContext;
typedef struct _generic_N_Vector *N_Vector;
typedef struct _generic_SUNMatrix *SUNMatrix;
typedef struct _generic_SUNLinearSolver *SUNLinearSolver;

typedef int (*CVRhsFn)(sunrealtype t, N_Vector y, N_Vector ydot, void *user_data);
typedef int (*CVRootFn)(sunrealtype t, N_Vector y, sunrealtype *gout, void *user_data);
typedef int (*CVLsJacFn)(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix Jac, void *user_data,
                         N_Vector tmp1, N_Vector tmp2, N_Vector tmp3);
typedef int (*CVLsPrecSetupFn)(sunrealtype t, N_Vector y, N_Vector fy, int jok, int *jcurPtr, sunrealtype gamma,
                               void *user_data);
typedef int (*CVLsPrecSolveFn)(sunrealtype t, N_Vector y, N_Vector fy, N_Vector r, N_Vector z, sunrealtype gamma,
                               sunrealtype delta, int lr, void *user_data);
typedef int (*CVProjFn)(sunrealtype t, N_Vector ycur, N_Vector corr, sunrealtype epsProj, N_Vector err,
                        void *user_data);
typedef void (*SUNErrHandlerFn)(int line, const char *func, const char *file, const char *msg,
                                SUNErrCode err_code, void *err_user_data, SUNContext sunctx);

#define CV_BDF 2
#define CV_NORMAL 1
#define CV_SUCCESS 0
#define CV_TSTOP_RETURN 1
#define CV_ROOT_RETURN 2
#define CV_TOO_MUCH_WORK (-1)
#define SUN_PREC_NONE 0
#define SUN_PREC_LEFT 1
#define SUN_CLASSICAL_GS 2

SUNErrCode SUNContext_Create(SUNComm comm, SUNContext *sunctx_out);
SUNErrCode SUNContext_Free(SUNContext *ctx);
SUNErrCode SUNContext_ClearErrHandlers(SUNContext sunctx);
SUNErrCode SUNContext_PushErrHandler(SUNContext sunctx, SUNErrHandlerFn err_fn, void *err_user_data);

N_Vector N_VNew_Serial(sunindextype vec_length, SUNContext sunctx);
void N_VDestroy(N_Vector v);
sunrealtype *N_VGetArrayPointer(N_Vector v);

SUNMatrix SUNBandMatrix(sunindextype N, sunindextype mu, sunindextype ml, SUNContext sunctx);
sunrealtype *SUNBandMatrix_Column(SUNMatrix A, sunindextype j);
void SUNMatDestroy(SUNMatrix A);
SUNLinearSolver SUNLinSol_Band(N_Vector y, SUNMatrix A, SUNContext sunctx);
SUNMatrix SUNDenseMatrix(sunindextype M, sunindextype N, SUNContext sunctx);
sunrealtype *SUNDenseMatrix_Data(SUNMatrix A);
SUNLinearSolver SUNLinSol_Dense(N_Vector y, SUNMatrix A, SUNContext sunctx);
SUNLinearSolver SUNLinSol_LapackDense(N_Vector y, SUNMatrix A, SUNContext sunctx);
SUNLinearSolver SUNLinSol_SPGMR(N_Vector y, int pretype, int maxl, SUNContext sunctx);
SUNErrCode SUNLinSol_SPGMRSetGSType(SUNLinearSolver S, int gstype);
SUNErrCode SUNLinSolFree(SUNLinearSolver S);

void *CVodeCreate(int lmm, SUNContext sunctx);
int CVodeInit(void *cvode_mem, CVRhsFn f, sunrealtype t0, N_Vector y0);
int CVodeSStolerances(void *cvode_mem, sunrealtype reltol, sunrealtype abstol);
int CVodeSetUserData(void *cvode_mem, void *user_data);
int CVodeSetLinearSolver(void *cvode_mem, SUNLinearSolver LS, SUNMatrix A);
int CVodeSetJacFn(void *cvode_mem, CVLsJacFn jac);
int CVodeSetDeltaGammaMaxLSetup(void *cvode_mem, sunrealtype dgmax_lsetup);
int CVodeSetPreconditioner(void *cvode_mem, CVLsPrecSetupFn pset, CVLsPrecSolveFn psolve);
int CVodeSetEpsLin(void *cvode_mem, sunrealtype eplifac);
int CVodeSetProjFn(void *cvode_mem, CVProjFn pfun);
int CVodeSetLSetupFrequency(void *cvode_mem, long int msbp);
int CVodeSetJacEvalFrequency(void *cvode_mem, long int msbj);
int CVodeSetMaxNonlinIters(void *cvode_mem, int maxcor);
int CVodeSetMaxConvFails(void *cvode_mem, int maxncf);
int CVodeRootInit(void *cvode_mem, int nrtfn, CVRootFn g);
int CVodeSetRootDirection(void *cvode_mem, int *rootdir);
int CVodeSetInitStep(void *cvode_mem, sunrealtype hin);
int CVodeSetMinStep(void *cvode_mem, sunrealtype hmin);
int CVodeSetMaxStep(void *cvode_mem, sunrealtype hmax);
int CVodeSetMaxOrd(void *cvode_mem, int maxord);
int CVodeSetMaxNumSteps(void *cvode_mem, long int mxsteps);
int CVodeSetMaxHnilWarns(void *cvode_mem, int mxhnil);
int CVode(void *cvode_mem, sunrealtype tout, N_Vector yout, sunrealtype *tret, int itask);
int CVodeGetCurrentTime(void *cvode_mem, sunrealtype *tcur);
int CVodeGetDky(void *cvode_mem, sunrealtype t, int k, N_Vector dky);
int CVodeGetNumSteps(void *cvode_mem, long int *nsteps);
int CVodeGetNumRhsEvals(void *cvode_mem, long int *nfevals);
int CVodeGetNumJacEvals(void *cvode_mem, long int *njevals);
int CVodeGetNumLinSolvSetups(void *cvode_mem, long int *nlinsetups);
int CVodeGetNumErrTestFails(void *cvode_mem, long int *netfails);
int CVodeGetNumNonlinSolvIters(void *cvode_mem, long int *nniters);
int CVodeGetNumNonlinSolvConvFails(void *cvode_mem, long int *nnfails);
int CVodeGetNumLinIters(void *cvode_mem, long int *nliters);
int CVodeGetNumLinConvFails(void *cvode_mem, long int *nlcfails);
int CVodeGetNumPrecEvals(void *cvode_mem, long int *npevals);
int CVodeGetNumPrecSolves(void *cvode_mem, long int *npsolves);
int CVodeGetNumJtimesEvals(void *cvode_mem, long int *njvevals);
int CVodeGetNumLinRhsEvals(void *cvode_mem, long int *nfevalsLS);
char *CVodeGetReturnFlagName(long int flag);
void CVodeFree(void **cvode_mem);
