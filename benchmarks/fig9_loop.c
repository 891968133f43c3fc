/* Fig 9 (eq 17) as one plain C99 loop: the practical speed limit for the benchmark.
 *
 * The same equations as bench_fig9.py's bare Python loop (docs/model.md: eqs 5-11 with
 * Karnopp friction, the unilateral surface, the hybrid controller of eqs 12-16
 * sampled at the servo rate), RK4 with a fixed step between ticks.
 *
 *   cc -O2 -o fig9_loop fig9_loop.c -lm
 *   ./fig9_loop RATE T_END STEP REPEAT
 *
 * Prints "seconds MEDIAN" then the C-X force at every tick (N) of the last run.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define PI 3.14159265358979323846

static const double L = 0.153, KW = 8e5, KR = 9e5, M3 = 0.58, M2 = 6.68, XS = 0.5, F0 = 10.0;
static const double TC[2] = {5.0, 3.5}, TS[2] = {5.75, 4.6}, EPS = 1e-4, TSTICK = 1e-3;
static const double KPP[2] = {460, 1650}, KPI[2] = {1.3, 1200}, KPD[2] = {30, 250};
static const double KFP[2] = {0.4, 0.3}, KFI[2] = {240, 220}, TMAX[2] = {0.004, 0.1};

static double fric(double v, double F, double m, int i) /* eq 11, Karnopp */
{
    if (fabs(v) >= EPS) return -copysign(TC[i], v);
    double b = -F - m * v / TSTICK;
    return b > TS[i] ? TS[i] : (b < -TS[i] ? -TS[i] : b);
}

static void rhs(const double x[8], const double tau[2], double dx[8])
{
    double q1 = x[0], q2 = x[1], v1 = x[2], v2 = x[3], w1 = x[4], w2 = x[5];
    double c = cos(q1), s = sin(q1);
    double pen = q2 * c + L * s + w1 * c - w2 * s - XS; /* eq 9, unilateral */
    double fx = pen > 0 ? KR * pen : 0.0;
    double f1 = KW * w1, f2 = KW * w2;
    double i1 = 3.98 - 5.25 * q2 + 6.47 * q2 * q2, m = M2 + M3;
    double F1 = tau[0] + q2 * f2 + L * f1, F2 = tau[1] + f1; /* eqs 5, 6 */
    dx[0] = v1; dx[1] = v2;
    dx[2] = (F1 + fric(v1, F1, i1, 0)) / i1;
    dx[3] = (F2 + fric(v2, F2, m, 1)) / m;
    dx[4] = x[6]; dx[5] = x[7];
    dx[6] = (-KW * w1 - fx * c) / M3; /* eqs 7, 8 */
    dx[7] = (-KW * w2 + fx * s) / M3;
}

/* one controller tick: tau from the state, integrators z updated; returns C-X force */
static double controller(double t, const double x[8], double z[4], double T, double tau[2])
{
    double q1 = x[0], q2 = x[1], c = cos(q1), s = sin(q1);
    double j11 = -q2 * s + L * c, j12 = c, j21 = q2 * c + L * s, j22 = s, det = j11 * j22 - j12 * j21;
    double Y = q2 * s - L * c, Yd = j21 * x[2] + j22 * x[3];
    double wt = 0.75 * PI, yd = 0.30 - 0.30 * cos(wt * t), vyd = 0.30 * wt * sin(wt * t);
    double fd = F0 + (t >= 1.0 ? F0 : 0.0);
    double ey = yd - Y, eyd = vyd - Yd; /* S = diag(1, 0): Y position-controlled */
    double qe[2] = {-j12 * ey / det, j11 * ey / det}, qde[2] = {-j12 * eyd / det, j11 * eyd / det};
    double cfx = c * (-KW * x[4]) - s * (-KW * x[5]);
    double dF = fd - cfx;
    double te[2] = {j11 * dF, j12 * dF}, tff[2] = {j11 * fd, j12 * fd};
    for (int i = 0; i < 2; i++) {
        z[i] += qe[i] * T;
        double e = te[i] > TMAX[i] ? TMAX[i] : (te[i] < -TMAX[i] ? -TMAX[i] : te[i]);
        z[2 + i] += e * T;
        tau[i] = KPP[i] * qe[i] + KPI[i] * z[i] + KPD[i] * qde[i] + tff[i] + KFP[i] * te[i] + KFI[i] * z[2 + i];
    }
    return cfx;
}

static void run(double rate, double t_end, double step, double *forces)
{
    double T = 1.0 / rate, ex = XS + F0 * (1 / KR + 1 / KW), z[4] = {0, 0, 0, 0}, tau[2];
    double q2 = sqrt(ex * ex - L * L), q1 = atan2(0.0, ex) + atan2(L, q2);
    double x[8] = {q1, q2, 0, 0, -F0 * cos(q1) / KW, F0 * sin(q1) / KW, 0, 0};
    int n = (int)lround(t_end * rate), m = (int)ceil(T / step - 1e-9);
    double h = T / m, k1[8], k2[8], k3[8], k4[8], y[8];
    for (int k = 0; k < n; k++) {
        forces[k] = controller(k * T, x, z, T, tau);
        for (int j = 0; j < m; j++) {
            rhs(x, tau, k1);
            for (int i = 0; i < 8; i++) y[i] = x[i] + 0.5 * h * k1[i];
            rhs(y, tau, k2);
            for (int i = 0; i < 8; i++) y[i] = x[i] + 0.5 * h * k2[i];
            rhs(y, tau, k3);
            for (int i = 0; i < 8; i++) y[i] = x[i] + h * k3[i];
            rhs(y, tau, k4);
            for (int i = 0; i < 8; i++) x[i] += h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
        }
    }
}

static int cmp(const void *a, const void *b)
{
    double d = *(const double *)a - *(const double *)b;
    return (d > 0) - (d < 0);
}

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: %s RATE T_END STEP REPEAT\n", argv[0]);
        return 2;
    }
    double rate = atof(argv[1]), t_end = atof(argv[2]), step = atof(argv[3]);
    int repeat = atoi(argv[4]), n = (int)lround(t_end * rate);
    double *forces = malloc(sizeof(double) * (n > 0 ? n : 1)), *secs = malloc(sizeof(double) * repeat);
    for (int r = 0; r < repeat; r++) {
        struct timespec a, b;
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &a);
        run(rate, t_end, step, forces);
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &b);
        secs[r] = (b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec);
    }
    qsort(secs, repeat, sizeof(double), cmp);
    printf("seconds %.9f\n", secs[repeat / 2]);
    for (int k = 0; k < n; k++) printf("%.17g\n", forces[k]);
    free(forces);
    free(secs);
    return 0;
}
