"""Fit cost of the Magic Formula stages in forward-evaluation equivalents.

For every MF stage of ``mfid fit`` on a measurement folder's trailer data: the stage's fit wall
time divided by the time of one full forward evaluation (every output, useMode 211, the numpy
reference path ``identify.model.evaluate.evaluate``) of the same points, both measured in this
run, so that the ratio does not depend on how fast or busy the machine is. The total is the MF
stages' wall time over one evaluation of all their points. The yardstick is the numpy path in
every version, so ratios of different versions compare the fits, not the kernels.

    python bench/fit_cost.py [--folder DIR] [--json out.json]
    python bench/fit_cost.py --ttc 0 [--save-table ttc0.pkl]   # a generated TTC session
    python bench/fit_cost.py --trailer table.pkl --fnomin 4980 --nompres 256600 --r0 0.3255
    python bench/fit_cost.py --trailer table.pkl ... --bin     # dense sweeps binned first
    python bench/fit_cost.py --import-first      # JAX imported before the timer
    python bench/fit_cost.py --trailer raw.pkl ... --bin --yardstick seg.pkl

``--trailer`` fits a pickled trailer table (pandas ``to_pickle`` of ``load_folder(...).trailer``,
e.g. of a TTC session imported on a branch whose reader the measured checkout lacks) with the
given nominal load [N], pressure [Pa] and unloaded radius [m], so that two checkouts fit the
same samples. ``--ttc SEED`` generates a TTC-style session in a temporary folder as
bench/ttc_truth.py does (``mfid simulate default DIR --format ttc --seed SEED``, then ``mfid
import`` of its two .mat runs with the truth's nominal pressure and unloaded radius: 135111
samples at seed 0) and fits it with ``--bin``. ``--save-table PATH`` pickles the table the MF
stages fit (binned with ``--bin``), so that an older checkout fits the same points with
``--trailer PATH`` (without ``--bin``). ``--bin`` selects the points as ``mfid fit`` does by
default
(identify.workflows.sweep_bins.mf_table: logged runs segmented, dense sweeps binned); that
step is part of the timed fit. The last line divides the MF stages' wall time by one evaluation of
every trailer sample (the same yardstick with and without binning, and in every version).
The ``cpu`` line divides the process's CPU time of the MF stages by the CPU time of one
evaluation of their points (best of REPEATS): on a loaded machine a process gets a varying
share of a core, which moves wall-time ratios by 2x between runs; CPU-time ratios move less.

Measured 2026-11-23 on the 2-core machine under a load average of 20-29 (the per-stage
yardsticks vary by 2-10x between runs at that load; the totals are the numbers to compare):
the bundled sample, total fit/eval 939 at ddb9f71 (MF stages 86.6 s), 310 and 421 in two runs
at e85cb99/7bca3d3 (49 s, 70 s); 507 with ``--jacobian fd``. A generated 136k-sample TTC
session (``mfid simulate default DIR --format ttc --seed 0``, ``mfid import DIR/*.mat``) with
``--bin``: MF stages 92.8 s, 68 evaluations of every trailer sample; ddb9f71 did not finish
on it (over 13 GB resident in its validity grid, then under 10 % of a core for 9 minutes).

Measured 2026-11-24 02:35-02:52 UTC, load average 12-15, back to back in one round each (the
``cpu`` ratios; wall ratios at that load moved by up to 2x between runs of the same code). The
bundled sample: 379 at ddb9f71; main before the fit-cost branch (0008732) 194 and 191 in two
rounds; the branch 152 and 152 (4537c6e, d4067b7): 2.5x ddb9f71, 1.26x main. The generated TTC
session, seed 0, its binned table (14642 points, ``--ttc 0 --save-table``, then ``--trailer``
in each checkout; ddb9f71 with main's validity grid at the data's pressure levels patched in,
as it otherwise builds one grid column per sample): 612 at ddb9f71; main 209 and 239; the
branch 214 and 209: 2.9x ddb9f71, 1.0-1.14x main. After merging main (787ab4d, load average
9.4): the sample 138 (wall 196), ``--ttc 0`` 207 (wall 303; 75 evaluations of every one of
the 135111 samples, binning included).

Measured 2026-11-24 05:18-05:19 UTC, load average 1.0-1.1, two rounds, each main at d022d60
(``git archive d022d60`` into /tmp, ``PYTHONPATH=/tmp/fitcost-before python bench/fit_cost.py
--label d022d60``: this script on that code) and then this branch (f41bdf6), back to back:
the bundled sample 139 and 132 -> 116 and 112 (cpu 137, 131 -> 117, 113); ``--ttc 0`` 208 and
206 -> 177 and 180 (cpu 211, 208 -> 180, 181). Per stage (round 2, sample / TTC): Fy0 429 ->
314 / 480 -> 369, Fy 178 -> 135 / 244 -> 177, Fx 93 -> 80 / 129 -> 115, the others within the
rounds' spread. The staged jackknife (``jackknife`` line, after the stages in mfid fit, not in
the total) 48 -> 17 on the sample and 65 -> 32 on the TTC session; stages and jackknife
together 180 -> 130 and 271 -> 212. Every fitted value the same (bit-identical but for the
search's merged starts: thesis errors per pressure within 1e-7 percentage points, coefficients
within 4e-6 of their standard errors, standard errors within 1.3e-5 relative, mfid fit
--no-report before and after). Against ddb9f71's 351 and 612 (earlier rounds, not this one):
3.1x and 3.4x, short of the issue's 5x. What the remaining ~115 evaluations of the sample are,
from step timings of one run: importing JAX 0.3 s (~13 evaluations, in the first stage's
time), tracing and loading each exact-Jacobian stage's compiled function 0.05-0.15 s (~20
together), the Fy0 and Mz0 searches on the subsample (~25; a curved valley the trust region
crawls along), their solves on all points and re-fits (~20); on the TTC session also the
binning before the stages (identify.segment.filters.revolution_average, ~15) and the Fy
stage's two candidates, both polished to the same constrained optimum (~15).

Measured 2026-11-24 07:13-07:15 UTC, load average 2.5-3.4, two rounds, each main at ef0d5ad
(``git archive main`` into /tmp/fitcost2-before, ``PYTHONPATH=/tmp/fitcost2-before python
bench/fit_cost.py --label main``) and then the stage-executable cache branch (a21fce8), back to
back, after one unmeasured run of each (the caches warm, as in a user's later runs): the
bundled sample 109 and 106 -> 92 and 94 (cpu 107, 105 -> 91, 92); ``--ttc 0`` 174 and 178 ->
160 and 164 (cpu 176, 175 -> 161, 163). What went (identify.fit.mf.jax_cache): tracing and
lowering each exact-Jacobian stage, 0.07-0.12 s a stage even with JAX's compilation cache,
now a stored executable loaded in 0.01-0.03 s; copying every chunk to the device (a
jnp.asarray per leaf, 0.1-0.2 s on the sample); the JAX import where no stage needs it (not
on these two sessions: it moved from the geometry stage to the first exact-Jacobian one,
Fy0 on the sample, Fx0 on the TTC session, whose ratios rose by it). Round 2 per stage,
sample / TTC: geometry 113 -> 16 / 181 -> 41, Mx and My 24 -> 17 / 44 -> 39. Against ddb9f71's
351 and 612 (earlier rounds): 3.8x on both, still short of 5x. ``--jacobian jax`` (exact
Jacobians for every stage) costs the same: 90 and 92 on the sample. Left, from step timings of
one run: importing JAX 0.27 s (~12 evaluations; importing it in a thread from the start of
``mfid fit`` moved it out of the MF stages but not out of the run: ``mfid fit --no-report``
on the sample 12.0-12.2 s either way, three runs each, as the import holds the GIL), running
the exact Jacobians 0.37 s (~16; 776 chunk calls), the trust-region solver's SVDs 0.28 s
(~12; scipy's trf with the exact solver), and the searches, solves and re-fits above; on the
TTC session the Fy stage's second candidate on all points (least squares 0.06 s, then the
constrained polish 0.22 s: ~12; it ends 0.04 % above the first's objective, but started below
it, so the polish's bound does not skip it). Every fitted
value the same: ``mfid fit --no-report`` fit.json of main and this branch identical but for
times and the command, on the sample (the cache warm, cold, and off) and on the TTC session.

Measured 2026-11-24 10:29-10:31 UTC, load average 3.0-4.0 (other helpers on the 2 cores), two
rounds, each main at 86aeafc (``git archive main`` into /tmp/fc3-main,
``PYTHONPATH=/tmp/fc3-main python bench/fit_cost.py --label fc3-main``) and then the fit-cost-3
branch (6888ca5), back to back, caches warm; the ``cpu`` lines (the wall ratios moved by 1.5x
between runs at that load): the bundled sample (``--passes 2``) 123 and 123 -> 104 and 95;
``--ttc 0 --passes 2`` 225 and 230 -> 177 and 177 (at 807f2f2, 10:18-10:21 UTC, load 3.9-4.5:
126 and 130 -> 101 and 101, 231 and 229 -> 188 and 183). After merging main (48d4eb7: the other
branch of Fx0, the conditional holds; 10:35-10:37 UTC, load 3.4-4.8, the same way against
48d4eb7 in /tmp/fc3-main2): the sample 122 and 125 -> 97 and 95, the TTC session 224 and 242 ->
172 and 185; fit.json against 48d4eb7's as below on both. What went (each from one-off profiles
of a warm ``fit_mf``, passes 2): the rivals' solves (identify.fit.mf.minima.rivals), which solved
every far candidate on all points again from the start the global fit had just solved, and
polished a polished one again, now replayed from the global fit's record where the budgets make
it the same solve (identify.fit.optimize.replay; with_rivals 0.39 -> 0.003 s on the sample;
nfev Fy 151 -> 103 and Fx 585 -> 482 on the sample, Fy 309 -> 175 and Fx 202 -> 156 on the TTC
session); a np.where copy of every Jacobian for its non-finite entries
(FitProblem.model_jacobian: ~1 ms of a 4096 x 27 Jacobian's ~2.5 ms) and indexing each chunk's
free columns instead of slicing them (identify.fit.mf.jacobian._runs); the jackknife
covariance's per-sweep decompositions (an eigvalsh, then an SVD in each of two pinv calls, a
Python loop over the sweeps each; now one stacked eigh: 42 -> 15 ms for 60 sweeps of a 6418 x
26 Jacobian, 157 -> 23 ms for 200 of 4495 x 29, synthetic, best of 5); and the stage's rows,
sweeps and pressure groups taken again for every re-fit and later pass (mf_problem.StagePoints:
stage_problem 0.96 -> 0.58 s on the TTC session, 0.52 -> 0.43 s on the sample), and the stage's
lmfit parameters built again after a screen that held nothing more. Every fitted value the
same: ``mfid fit --no-report`` fit.json of main and the branch, on the sample and on the TTC
session (seed 0, simulated and imported as ``--ttc`` does): coefficients, thesis errors,
objectives, statuses, messages and rivals identical; standard errors within 1.5e-11 relative,
degrees of freedom within 5.3e-11 and a rival's chi^2 within 2.3e-13 (the eigendecomposition).
Against ddb9f71's 351 and 612 (earlier rounds, other loads): 3.5x and 3.5x, short of the
issue's 5x (72 and 122). Left, from a profile of the TTC session's stages (4.5 s): the exact
Jacobians 1.45 s (1772 chunk calls, 0.6-0.8 ms of CPU each, compute, not dispatch: reading
every chunk's result after dispatching them all changed nothing), trf's SVDs 0.7 s (620;
scipy's gesdd of the whole n x k Jacobian, near LAPACK's cost: a QR first was slower, gesvd ~30
% faster but is scipy's choice inside trf, and a change to the steps could move the
noise-stopped optima by more than the 1e-3 of a standard error allowed: not tried), the model
evaluations ~0.5 s, the SLSQP polishes 0.47 s (each gradient a whole exact Jacobian), the stage
builds 0.58 s and the JAX import 0.3 s.

Measured 2026-11-24 10:44-10:45 UTC on main after the merge (d985d29), load average 1.6-2.9, one
round, ``--passes 2`` (``mfid fit``'s default): the sample 103 (cpu 104), ``--ttc 0`` 177 (cpu
184); against ddb9f71's 351-379 and 612: 3.4-3.6x and 3.3-3.5x.

Measured 2026-11-24 13:04-13:08 UTC, load average 1.3-2.9 (other helpers on the 2 cores), two
rounds twice, each main at 3e0c61b (``git archive`` into /tmp/fc4/main, ``PYTHONPATH=/tmp/fc4/main
python bench/fit_cost.py --passes 2 --label main-3e0c61b``, and the same with ``--ttc 0``) and
then the fit-cost-4 branch, back to back, caches warm; the ``cpu`` lines: at cf3c0a2 the
sample 102 and 102 -> 88 and 92, the TTC session 177 and 180 -> 147 and 149; at 261934a the
sample 103 and 103 -> 91 and 88, the TTC session 176 and 184 -> 143 and 139 (wall 172 -> 138
and, in a load spike on main's run, 309 -> 137). Against ddb9f71's 351-379 and 612 (earlier
rounds), over the four ``cpu`` lines: 3.8-4.3x and 4.1-4.4x, still short of the issue's 5x
(72 and 122). What went (CPU times of warm fit_mf runs and step timings, one-off): trf's SVDs
through a QR first with U
never formed (identify.fit.solve.trf_svd: 35-50 % of gesdd's time; a warm TTC fit_mf 3.09 -> 2.72 s
wall); exact Jacobians from 30_000 points x coefficients (mf_jacobian.MIN_WORK, was 50_000: the
sample's Fx0 0.20 -> 0.09 s); Mz0's mirror images (QBZ9, QBZ10) -> (-QBZ9, -QBZ10) taken as
one optimum by the search, as candidates and as a start's stop (the TTC session's second Mz0
candidate, solved on all points for 37 evaluations, was the first's mirror image; Mz0 nfev
256 -> 201 there, 119 -> 102 on the sample); an Fy0 program without the combined-slip
expression where no point has kappa != 0 (the sample: Fy0 0.60 -> 0.52 s); the least-squares
polish's gradient reusing the residuals its objective just computed (Fy nfev 179 -> 131 on
the TTC session); on the TTC session the binning (identify.segment.filters: the kept rows
copied once, not per stretch; short NaN runs filled only in the columns with one; mf_table
0.55 -> 0.33 s, the table bit-identical). Fitted values: ``mfid fit --no-report`` fit.json of
main and the branch: the MF coefficients within 2e-5 of their standard errors (sample) and
1.1e-5 (TTC session), standard errors within 5.5e-7 relative (sample) and 5.9e-4 (the TTC
session's geometry DREFF, whose standard error is 23 times its value; the others within
3.3e-7), thesis errors within 1.2e-7 percentage points; rivals the same (to 1e-5 relative);
the stop criterion named in some stages' messages and statuses differs (the round-off of the
QR route, the exact Jacobian of the sample's geometry and Fx0 stages), and the TTC session's
Mz0 reports 3 starts at the best instead of 1 (its mirror-image starts now count). Left (the
sample's ~90 evaluations, ~2.1 s CPU): importing JAX 0.3 s; the Fy0 and Mz0 searches on the
4096-point subsample (~0.55 s: per trust-region iteration the exact Jacobian ~55 %, the SVD
~25 %, near their floors: a 2048-point chunk's forward-mode Jacobian of 27 coefficients costs
3-4 evaluations of the chunk); their solves on all points and re-fits (~0.35 s); on the TTC
session also the binning (0.33 s) and the Fy stage's two constrained polishes (~0.25 s).
After merging main (effd982; main at ce1e6cd, 13:21-13:23 UTC, load average 1.8-2.4, two
rounds, ``git archive main`` into /tmp/fc4/main2, the same way): the sample 99 and 101 -> 91 and
88; the TTC session 271 and 274 -> 232 and 235. main's TTC session changed with 18276a1 (the
generator's slip ratio scatters about 0 in cornering runs: 135121 samples) and 7ceb1da (such
runs' points taken at kappa = 0): on it the Mz0 stage crawls along a valley, both search starts
from the carried-forward and the default values ending at SEARCH_NFEV (200; chi^2 still
falling by ~0.008 an iteration, above the noise stop's 0.02 per 5) and both candidates' solves
on all points at MAX_NFEV (100), before the re-fit with QEZ4, QEZ5 converges in 8: Mz0 3.3 s
and 678 evaluations on main, 2.7 s and 690 here (one run each), where it took 0.8 s on the
session before. A search noise stop of 5e-2 or 1e-1 s^2 (instead of 1e-2) saved 6 % of that
fit but found a second rival of Fx0: not taken. fit.json of ce1e6cd and effd982 (``mfid fit
--no-report``): MF coefficients within 2e-5 (sample) and 1.1e-5 (TTC session) of their
standard errors, standard errors within 5.5e-7 and 5.9e-4 (DREFF, as above) relative, thesis
errors within 2.3e-7 percentage points, rivals the same to 4.5e-6 relative.

Measured 2026-11-24 13:57-13:59 UTC at b047b78 (the merge, the crawl status of
engine.Tolerances.crawl_ftol and the combined-slip bounds), load average 0.9-1.5, one round,
``--passes 2``: the sample 99 (cpu 94); ``--ttc 0`` 245 (cpu 261; 100 evaluations of every
one of the 135121 samples), of which Mz0 1411 on its own (2.8 s, 655 evaluations: the crawl
above). Against ddb9f71's 351-379 on the sample: 3.5-3.8x. The TTC session is not the one
ddb9f71's 612 was measured on (the generator changed with 18276a1), so no ratio is claimed for
it; on the session before that change this code's predecessor measured 4.2-4.4x (above).

Measured 2026-11-24 (session 8) at 09b012b, load average 0.6-0.8, one sitting, ddb9f71 (its
archive with the validity-grid patch above, ``PYTHONPATH=/tmp/before``) and then this code, on
the bundled sample and on the binned table of the current generator's TTC session, seed 0 (14877
points: ``--ttc 0 --save-table t.pkl``, then ``--trailer t.pkl --fnomin 5000 --nompres 250000
--r0 0.3205`` in each checkout, ``--passes 2`` in this one); the ``cpu`` lines: the sample 365
-> 92 (4.0x), the TTC session 590 -> 155 (3.8x), short of the issue's 5x. What went: the
dogleg after 50 evaluations (engine.DOGLEG_AFTER; the TTC session's Mz0 655 -> 360
evaluations, 2.7 -> 1.3 s, its objective the same to 3e-14) and the polish's stall test
(engine._PolishStall: on seed 2's session the Fy stage 5.2 -> 0.4 s, 3540 -> 104
evaluations); every fitted value of the sample bit for bit the same, of the TTC sessions of
seeds 0, 1 and 2 within 6.1e-7 standard errors; at seed 4 the geometry stage (DREFF, FREFF,
BREFF along their valley) ended 0.05 standard errors away, its objective 2e-5 higher, and the
stages after it within 5.2e-5 (a one-off /tmp script, fit_mf before and after). Left: the
JAX import, ~0.3 s in the first exact-Jacobian stage (13 evaluations of either session;
without it 79 and 142: 4.6x and 4.2x), then the Fy0 and Mz0 searches and solves as above.

Measured later that session at de43ff4 (the search's subsample one chunk of 2048 points,
mf_search.SUBSAMPLE; run_sweeps once per fit), load average 0.8-0.9, one sitting, ddb9f71
(``PYTHONPATH=/tmp/before``, as above) and then this code with and without ``--import-first``:
``cpu`` lines, the sample 354 -> 82 (4.3x) with the JAX import in the timed fit, 67 (5.3x)
without it; the TTC session's table 628 -> 135 (4.65x) and 120 (5.2x); the wall-time
``total`` lines 354 -> 81 and 66, 627 -> 132 and 116. Fitted values: the subsample within
6e-7 standard errors of 4096's (sample, TTC seeds 0 and 2), run_sweeps bit for bit. Tried and
not kept: stopping a solve that crawls with the dogleg too (10 iterations in a row below
crawl_ftol; Mz0 on the TTC session 1.00 -> 0.82 s), which left the golden tyre's session
(bench/ttc_truth.py --tir tests/data/tir/testA_61.tir, seed 0) at 17 % on Fy; a larger
MERGE_CHI2 (9: no change); the dogleg on crawl detection before 50 evaluations (no change).

Measured 2026-11-24 (session 9) at 0ce2daa, load average 0.9-1.2, one sitting, on the
segmented session the issue names: the generated TTC session of seed 0 (135121 samples)
segmented as ``mfid fit`` does but not binned (82094 points: identify.workflows.sweep_bins.mf_table
with ``alpha_deg=kappa=None``, pickled once, ``--yardstick`` of every run below). ddb9f71
(``PYTHONPATH=/tmp/before``, the archive above) fitting those 82094 points: ``cpu`` 717 (78.5 s
CPU; Fx stopped at its evaluation limit), ``samp-cpu`` 2482. This code on the same 82094 points
(``--trailer seg.pkl --passes 2``, JAX's import inside the timed fit): ``cpu`` 100 (11.4 s), 7.2x;
``samp-cpu`` 365, 6.8x. This code as ``mfid fit`` runs it, segmenting and binning the 135121
samples inside the timed fit (``--trailer raw.pkl --bin --passes 2 --yardstick seg.pkl``):
``samp-cpu`` 113 (3.45 s), 22x. On the bundled sample (12074 points, no binning), the same
sitting (``PYTHONPATH=/tmp/before python bench/fit_cost.py --label ddb9f71``, then ``python
bench/fit_cost.py --passes 2 [--import-first]``): ``cpu`` 356 -> 83 (4.3x) with the import
(0.31 s of CPU, ~13 evaluations of its points), 69 (5.1x) without it (5.3x at de43ff4):
its fit is 1.6 s, where the fixed costs (import, stage builds, loading the stored
executables) do not shrink with the data.

Measured 2026-11-24 (session 10) at 42f5bf0, load average 1.0-1.4, one sitting: ddb9f71
(``PYTHONPATH=/tmp/before python bench/fit_cost.py --label ddb9f71``, twice) ``cpu`` 336 and
343; this code (``python bench/fit_cost.py --passes 2``, three times) 69, 71 and 75 with the
JAX import in the timed fit (4.5-5.0x), 58 with ``--import-first`` (5.9x). What went: the MF
solves stop at a Gauss-Newton decrement below the noise stop's bound
(identify.fit.solve.engine.Tolerances.decrement_stop: the sample's Fy0 193 -> 151 evaluations, Mz0
92 -> 75; every coefficient within 0.0045 of its standard error of main's, ``mfid fit
--no-report`` fit.json compared) and the screen's Gram-Schmidt in matrix products; a warm
fit_mf (passes 1, JAX imported) 1.44 -> 1.21 s of CPU. Of the 1.7 s left: the JAX import
0.28 s, loading seven stored executables 0.08 s, Fy0 0.43 s and Mz0 0.32 s (their searches'
three starts on the subsample and the solves on all points). ``--ttc 0 --passes 2``: ``cpu``
134 (c35cff2 with passes 1, earlier this session: 143; ddb9f71 612-628 on its binned table
in earlier rounds). After the review (4117235: one kept Jacobian, the decrement by
trf_svd.tall_svd; fit.json of the sample unchanged), the same commands in one sitting, load
1.3-1.4: ddb9f71 339 and 336; this code 71, 71 and 72 (4.7-4.8x), 58 with ``--import-first``
(5.8x).

Measured 2026-11-24 (session 11) at c905ae6, load average 1.2-1.3, one sitting: ddb9f71
(``PYTHONPATH=/tmp/before python bench/fit_cost.py --label ddb9f71``, twice) ``cpu`` 342 and
345; this code (``python bench/fit_cost.py --passes 2``, three times) 67, 67 and 67 with the
JAX import in the timed fit (5.1x), 51 with ``--import-first`` (6.7x); in an earlier sitting
that day (load 0.4-0.5) 336 -> 64 and 62 (5.3-5.4x), 49 without the import. What went: the
MF solves on all points start with full Gauss-Newton steps inside the bounds
(identify.fit.solve.gauss_newton: the sample's Fy0 151 -> 132 evaluations, Mz0 84 -> 78; its two
Fy0 solves on all points 16 and 15 -> 5 and 6), a warm fit_mf 1.26 -> 1.06 s of CPU (passes
2, three runs each in one process, a one-off /tmp script), every
coefficient within 0.0045 of its standard error of c8c26be's (mfid fit --no-report).
``--ttc 0 --passes 2``: ``cpu`` 128 (134 at c8c26be).

Measured 2026-11-24 (session 12) at 8be0da9, load average 1.0-1.2, one sitting: ddb9f71 358
and 354; this code 68 and 68 (5.2-5.3x), 52 with ``--import-first`` (6.8-6.9x). The re-fits with
coefficients freed after the global fit now also start from Latin-hypercube points
(identify.fit.mf.stages._refine; 74 with them alone), and the search's starts begin with
Gauss-Newton steps (identify.fit.solve.engine.SEARCH), which pays for them on the sample. Not on
the TTC session: ``--ttc 0 --passes 2`` ``cpu`` 144 (128 before; ddb9f71 612-628, 4.3x).

Runs on the code of the checkout it is in (also an older one: it falls back to the old module
paths), on one BLAS thread.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from identify.fit.mf.stages import fit_mf  # noqa: E402
from identify.model.evaluate import evaluate  # noqa: E402
from identify.model.parameters import defaults  # noqa: E402

try:
    from identify.io.folder import load_folder  # noqa: E402
except ImportError:  # versions before the io layer
    from identify.load.folder import load_folder  # noqa: E402
try:
    from identify.fit.mf.uncertainty import propagate  # noqa: E402
except ImportError:  # versions before the staged jackknife
    propagate = None

ROOT = Path(__file__).resolve().parents[1]
FOLDER = ROOT / "measurements" / "sample-225-50R17"
REPEATS = 5


def start_values(fnomin: float, nompres: float, r0: float | None) -> dict[str, float]:
    """Where ``mfid fit`` starts: MFeval defaults with the folder's nominal conditions."""
    base = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    base["FNOMIN"] = float(fnomin)
    base["NOMPRES"] = base["INFLPRES"] = float(nompres)
    if r0:
        base["UNLOADED_RADIUS"] = float(r0)
    return base


def evaluation_seconds(params: dict, points, clock=time.perf_counter) -> float:
    """Best of REPEATS times of one full forward evaluation of ``points`` [s] (wall time, or
    ``clock=time.process_time`` for CPU time)."""
    cols = {c: points[c].to_numpy(float) for c in ("Fz", "kappa", "alpha", "gamma", "Vx", "p")}
    omega = points["omega"].to_numpy(float) if "omega" in points else None
    best = np.inf
    for _ in range(REPEATS):
        t0 = clock()
        evaluate(params, cols["Fz"], cols["kappa"], cols["alpha"], cols["gamma"], cols["Vx"],
                 p=cols["p"], omega=omega, mode=211)
        best = min(best, clock() - t0)
    return best


def ttc_session(seed: int, where: Path):
    """A generated TTC session imported into ``where``/folder (see module): the loaded
    measurement set. Not in versions before the TTC reader: imported here."""
    from identify.io.tir import read_tir
    from identify.simulate import default_tir_path
    from identify.simulate.ttc import simulate_ttc
    from identify.workflows.import_session import import_session

    simulate_ttc(read_tir(default_tir_path()).params(), where / "ttc", seed=seed)
    truth = json.loads((where / "ttc" / "truth.json").read_text())["tir"]
    imp = import_session(sorted((where / "ttc").glob("*.mat")), where / "folder",
                         nominal_pressure_Pa=float(truth["NOMPRES"]),
                         unloaded_radius_m=float(truth["UNLOADED_RADIUS"]))
    return load_folder(imp.path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--folder", type=Path, default=FOLDER)
    ap.add_argument("--json", type=Path, help="write the numbers to this file")
    ap.add_argument("--trailer", type=Path, help="a pickled trailer table instead of --folder")
    ap.add_argument("--fnomin", type=float, help="--trailer: nominal load [N]")
    ap.add_argument("--nompres", type=float, help="--trailer: nominal pressure [Pa]")
    ap.add_argument("--r0", type=float, help="--trailer: unloaded radius [m]")
    ap.add_argument("--passes", type=int, default=None,
                    help="passes over the MF stages (default: fit_mf's, 1; mfid fit runs "
                         "FitSettings.mf_passes, 2 since f7d0963)")
    ap.add_argument("--yardstick", type=Path,
                    help="a pickled table: the samples lines divide by one evaluation of its "
                         "points instead of the fitted table's")
    ap.add_argument("--label", default="", help="name of the code measured (default: git HEAD)")
    ap.add_argument("--bin", action="store_true",
                    help="segment logged runs and bin dense sweeps first, as mfid fit does")
    ap.add_argument("--ttc", type=int, metavar="SEED",
                    help="fit a generated TTC session of this seed (implies --bin)")
    ap.add_argument("--save-table", type=Path, metavar="PATH",
                    help="pickle the table the MF stages fit (for --trailer elsewhere)")
    ap.add_argument("--import-first", action="store_true",
                    help="import JAX (identify.fit.mf.jacobian.available) before the timer: "
                         "the fit's cost without the one-off import a process pays once")
    ap.add_argument("--jacobian", choices=("auto", "fd", "jax"),
                    help="MFID_JACOBIAN for this run (identify.fit.mf.jacobian; default: as set)")
    args = ap.parse_args()
    if args.jacobian:
        os.environ["MFID_JACOBIAN"] = args.jacobian
    tmp = None
    if args.trailer:
        trailer = pd.read_pickle(args.trailer)
        base = start_values(args.fnomin, args.nompres, args.r0)
        name = args.trailer.name
    else:
        if args.ttc is not None:
            tmp = tempfile.TemporaryDirectory(prefix="fit_cost_ttc")
            mset = ttc_session(args.ttc, Path(tmp.name))
            args.bin = True
            args.folder = Path(f"ttc-seed{args.ttc}")
        else:
            mset = load_folder(args.folder)
        tyre = mset.manifest.tyre
        trailer = mset.trailer
        base = start_values(tyre.nominal_load_N, tyre.nominal_pressure_Pa,
                            tyre.unloaded_radius_m)
        name = args.folder.name
    imported = ""
    if args.import_first:
        try:
            from identify.fit.mf.jacobian import available
            t_imp = time.perf_counter()
            imported = (f"; JAX imported before the timer ({time.perf_counter() - t_imp:.2f} s)"
                        if available() else "; no JAX to import")
        except ImportError:  # versions before the exact Jacobians import nothing
            imported = "; no JAX in this version"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        t0, c0 = time.perf_counter(), time.process_time()
        table = trailer
        if args.bin:
            from identify.fit.run import FitSettings  # not in versions before binning
            from identify.workflows.sweep_bins import mf_table, segment_settings

            s = FitSettings()
            table, _ = mf_table(trailer, base["FNOMIN"], segment=s.segment,
                                settings=segment_settings(s))
        passes = {} if args.passes is None else {"passes": args.passes}
        mf = fit_mf(table, base, **passes)
        total_fit = time.perf_counter() - t0
        total_cpu = time.process_time() - c0
        jk_fit = None
        if propagate is not None:  # the staged jackknife mfid fit runs next (not in total)
            t1 = time.perf_counter()
            propagate(table, mf)
            jk_fit = time.perf_counter() - t1
    if args.save_table:
        table.to_pickle(args.save_table)
    if tmp is not None:
        tmp.cleanup()
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    commit = args.label or commit
    print(f"{name} at {commit} (MFID_JACOBIAN={os.environ.get('MFID_JACOBIAN', 'auto')}): "
          f"{len(trailer)} trailer samples{f', binned to {len(table)}' if args.bin else ''}; "
          f"yardstick: numpy evaluate(), all outputs, useMode 211, best of {REPEATS}{imported}")
    print(f"{'stage':9} {'points':>7} {'fit s':>8} {'eval ms':>8} {'fit/eval':>9} {'nfev':>7} "
          f"{'conv':>4}  message")
    rows, all_eval = [], 0.0
    for r in mf.results:
        pts = mf.points[r.form]
        t_eval = evaluation_seconds(mf.params, pts)
        all_eval += t_eval
        nfev = int(getattr(r, "nfev", 0))
        rows.append({"stage": r.form, "points": int(len(pts)), "fit_s": r.seconds,
                     "eval_s": t_eval, "ratio": r.seconds / t_eval, "nfev": nfev,
                     "converged": bool(r.converged), "message": r.message})
        print(f"{r.form:9} {len(pts):7d} {r.seconds:8.2f} {1e3 * t_eval:8.2f} "
              f"{r.seconds / t_eval:9.0f} {nfev or '':>7} {'yes' if r.converged else 'NO':>4}  "
              f"{r.message[:60]}")
    print(f"{'total':9} {sum(x['points'] for x in rows):7d} {total_fit:8.2f} "
          f"{1e3 * all_eval:8.2f} {total_fit / all_eval:9.0f}")
    if jk_fit is not None:
        print(f"{'jackknife':9} {sum(x['points'] for x in rows):7d} {jk_fit:8.2f} "
              f"{1e3 * all_eval:8.2f} {jk_fit / all_eval:9.0f}  (the staged jackknife after the "
              f"stages, identify.fit.mf.uncertainty.propagate; not in total)")
    cpu_eval = sum(evaluation_seconds(mf.params, mf.points[r.form], time.process_time)
                   for r in mf.results)
    print(f"{'cpu':9} {sum(x['points'] for x in rows):7d} {total_cpu:8.2f} "
          f"{1e3 * cpu_eval:8.2f} {total_cpu / cpu_eval:9.0f}  (CPU times: MF stages / one "
          f"evaluation of their points)")
    yard = trailer if args.yardstick is None else pd.read_pickle(args.yardstick)
    what = "trailer sample" if args.yardstick is None else f"point of {args.yardstick.name}"
    every = evaluation_seconds(mf.params, yard)
    print(f"{'samples':9} {len(yard):7d} {total_fit:8.2f} {1e3 * every:8.2f} "
          f"{total_fit / every:9.0f}  (MF wall time / one evaluation of every {what})")
    every_cpu = evaluation_seconds(mf.params, yard, time.process_time)
    print(f"{'samp-cpu':9} {len(yard):7d} {total_cpu:8.2f} {1e3 * every_cpu:8.2f} "
          f"{total_cpu / every_cpu:9.0f}  (CPU times: MF stages / one evaluation of every "
          f"{what})")
    if args.json:
        args.json.write_text(json.dumps({"folder": name, "commit": commit,
                                         "stages": rows, "total_fit_s": total_fit,
                                         "total_eval_s": all_eval,
                                         "total_ratio": total_fit / all_eval,
                                         "samples": len(trailer), "binned": bool(args.bin),
                                         "samples_eval_s": every,
                                         "samples_ratio": total_fit / every,
                                         "total_cpu_s": total_cpu, "eval_cpu_s": cpu_eval,
                                         "jackknife_s": jk_fit,
                                         "jackknife_ratio": (None if jk_fit is None
                                                             else jk_fit / all_eval),
                                         "cpu_ratio": total_cpu / cpu_eval}, indent=1))


if __name__ == "__main__":
    main()
