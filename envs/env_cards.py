"""The environment cards' shared text: the sections every tuning environment's docstring ends with.

Gymnasium documents an environment in its class docstring (Description, Action Space, Observation
Space, Rewards, Starting State, Episode End, Arguments, Version History).  Each structure's class in
:mod:`envs.tuning_env` joins its Description (``PID_DESCRIPTION``, ...) and the shared sections;
docs/environments/ is generated from those docstrings (``agents.environment_pages``).
"""

__all__ = ["SHARED_DOC", "VERSION_HISTORY", "PID_DESCRIPTION", "FPPI_DESCRIPTION", "MSP_DESCRIPTION", "PI_DESCRIPTION",
           "PI_VERSION_HISTORY"]

SHARED_DOC = """
    ## Action Space
    ``experiments="fixed"``: ``Box(-1, 1, (1,), float32)``, the design parameter ``p`` in the
    coordinate of ``action``: ``"parameter"`` (v0), a log scale over ``[p_min, p_max]``,
    ``p = p_min (p_max/p_min)^((a + 1)/2)``; ``"residual"`` (v1-v3), around the base rule's ``p_0``
    (Description), ``p = p_0 (p_max/p_0)^a`` for ``a >= 0`` and ``p_0 (p_0/p_min)^a`` below, so that
    action 0 is the rule and ``+-1`` the ends of the range; ``"robustness"``, the robustness target of
    the loop on the model (Description), for which the parameter is solved (:mod:`envs.base_design`).

    ``experiments="agent"``: ``Box(-1, 1, (n + 3,), float32)`` with ``n`` the experiment types
    (stable plants: closed-loop step, open-loop step, open-loop ramp, relay, and with
    ``identification="least-squares"`` a PRBS; integrating plants: closed-loop step, pulse, relay;
    see :mod:`envs.episode`):

    | index     | meaning                                                                      |
    |-----------|------------------------------------------------------------------------------|
    | 0         | score of "commit the design"                                                 |
    | 1 .. n    | score of each experiment type; the largest of 0 .. n is the choice            |
    | n + 1     | amplitude ``a`` of the experiment, log scale over [0.1, 10] (unit output change) |
    | n + 2     | the design parameter, as in the fixed mode (read when committing)            |

    ``experiments="plan"``: ``Box(-1, 1, (3,), float32)``: the first step reads the amplitudes of the
    fixed procedure's two experiments (index 0: the closed-loop step, 1: the open-loop step, or the pulse for
    integrating plants; log scale over [0.1, 10] as above, cut to ``amplitude_limit``), runs both and
    shows the identification;
    the second step designs from index 2, as in the fixed mode.  A plan of amplitudes (1, 1) is the
    fixed mode's procedure, bit for bit.

    With ``experiment_set="design"`` (v3) the agent mode's ``n`` experiment types are those the
    structure's design or design features read (:data:`envs.episode_options.DESIGN_EXPERIMENTS`): PID
    closed-loop step, open-loop step, relay; FPPI closed-loop step, open-loop step; MSP closed-loop
    step, pulse.

    Actions outside [-1, 1] are clipped to it; a NaN or infinite action raises ``ValueError``.

    ``discrete_action=True`` (agent mode with ``design_step``, v2-v3): ``Discrete(5 (n + 1) + 21)``,
    for learners that choose among actions (sb3-contrib's ``MaskablePPO``), each index one ``Box``
    action of the same meaning (:mod:`envs.discrete_action`): indices 0-4 commit at amplitude 0.1, 0.3,
    1, 3 or 10; then five per experiment type (in the order of ``experiment_names``), the experiment at
    those amplitudes; then 21 design levels, the residual action -1, -0.9, ..., 1 (0: the base rule).
    ``action_masks()`` gives the indices that mean something now: in the design step the 21 design
    levels only; before it the commits, and the experiments while the budget lasts; amplitudes above
    ``amplitude_limit`` masked (v3: 10).  A masked index still acts as its ``Box`` action: an experiment
    beyond the budget commits, a design level before the design step commits at amplitude 1, a commit
    or experiment in the design step designs at the base rule.  The step's info names the index
    (``action``: ``"open-loop-step@3"``, ``"commit@1"``, ``"design@-0.2"``).  An index out of range, or
    not an integer, raises ``ValueError``.

    ## Observation Space
    ``Box(-5, 5, (10 + n + 1,), float32)``, every entry dimensionless (identified ``T_ar`` and
    ``K_n`` as units): the ten identified features of :data:`envs.episode.FEATURES` (with
    ``identification="least-squares"``, three more: :data:`envs.episode.LEAST_SQUARES_FEATURES`);
    then the runs of each experiment type, and of all, over the budget; then, as their options are on,
    ``failed_experiments``, the three design features and ``design_step`` (the table).  A feature whose
    experiment has not run (or failed) is 0, and the counts tell which ran.

    | feature | measured by | value |
    |---|---|---|
    | `tau` | `closed-loop-step` | normalized dead time ``1 - T_a/T_ar`` (Gorez & Klan eq. 2-7), from the moments of the closed-loop step's record |
    | `theta` | `closed-loop-step` | ``theta`` of the SOPDT model (Gorez & Klan eq. 2-10), from the same moments |
    | `dead_time_fraction` | `open-loop-step` | ``L_n/T_ar`` of the open-loop step's FOPDT model (Ingimundarson & Hagglund eq. 11) |
    | `log_mismatch` | `open-loop-step` | ``log10(T_f_bar/T_n)``, the mismatch area of the open-loop step (Ingimundarson & Hagglund eq. 22) |
    | `log_pulse_area` | `pulse` | ``log10(A/(K_n L_n))``, the area of the pulse experiment (Ingimundarson & Hagglund eq. 46; pulse ``a/(K_n tau_p)`` of length ``tau_p = L_n/3``) |
    | `log_noise_ratio` | `closed-loop-step` | ``log10(sigma/a)`` of the closed-loop step at amplitude ``a``; with ``measured_observation=True`` (v3) ``sigma`` is estimated from the step's record (the median absolute fourth difference over ``0.6745 sqrt(70)``, :func:`envs.identification.steady_state.noise_level`; with `quantization`, the estimate that knows the sensor's resolution, :func:`envs.identification.quantized_noise.quantized_noise_level`), in v0-v2 it is the configured ``noise_std`` |
    | `log_relay_gain` | `relay` | ``log10(K_u |K_n|)``, the ultimate gain of the relay experiment (hysteresis ``3 sigma``) |
    | `relay_period` | `relay` | ``P_u/T_ar``, the relay's period |
    | `ramp_time_constant` | `open-loop-ramp` | ``T_n/T_ar`` from an open-loop ramp (Ingimundarson & Hagglund eq. 12) |
    | `log_experiment_time` | - | ``log10(1 + t_exp/T_ar)``, the experiment time so far |
    | `count_<type>` | - | runs of each experiment type over the budget |
    | `budget_used` | - | all runs over the budget |
    | `failed_experiments` | - | ``measured_observation=True`` (v3): runs that gave nothing usable (stopped at the excursion limit, or a closed-loop step without a usable gain and ``T_ar``) over the budget |
    | `ls_time_constant` | `prbs` | ``identification="least-squares"``: the latest least-squares fit's time constant over ``T_ar`` |
    | `ls_dead_time` | `prbs` | ``identification="least-squares"``: that fit's dead time over ``T_ar`` |
    | `log_ls_residual` | `prbs` | ``identification="least-squares"``: ``log10`` of that fit's residual over the amplitude |
    | `log_base_parameter` | - | ``design_features=True`` (v1-v3): ``log10 p_0``, the base rule's parameter |
    | `check_ms` | - | ``design_features=True`` (v1-v3): ``Ms`` of the base design's loop closed around the *other* identified model (Description), clipped to [1, 5], 5 if unstable |
    | `check_delay_margin` | - | ``design_features=True`` (v1-v3): that loop's delay margin over ``T_ar``, clipped to [0, 5], 0 if unstable |
    | `design_step` | - | plan mode, and agent mode with ``design_step=True`` (v2-v3): 1 when the next step designs |

    ## Rewards
    ``r = -cost`` on the step that commits the design, 0 on experiment steps, where
    (:mod:`envs.analysis.scoring`) ``cost = w_load IAE_load/(|K| T_ar) + w_sp IAE_sp/T_ar + w_exp t_exp/T_ar
    + w_prod D_exp/T_ar`` (``D_exp = int |y| dt`` of the true output over the experiments; ``w_prod = 0``
    by default) on the TRUE plant (``K``, ``T_ar`` true; integrating plants: ``IAE_load/(|K_v| T_ar^2)``),
    capped at 20 when the loop meets the constraints.  A design that violates them costs, with ``g``
    the sum of its relative violations (:func:`envs.analysis.scoring.violation_cost`):
    ``violation_cost="graded"`` (v0-v2) ``21 + g``, an unstable loop 26; ``violation_cost="bounded"``
    (v3) ``21 + 5 g/(1 + g)``, an unstable loop 26, so that every violation costs more than every
    feasible design and no stable loop more than an unstable one.  The cost is the one of
    ``deadtime analyze`` and :func:`envs.analysis.scoring.score` for the same plant and controller.

    ## Starting State
    A plant drawn from ``family`` with ``self.np_random`` (or ``options["plant"]`` of ``reset``, any
    form :func:`envs.systems.plants.as_plant` takes).
    Fixed mode: the fixed procedure has run (:func:`envs.identification.procedure.identify`: closed-loop step,
    then open-loop step, or pulse for integrating plants, amplitude 1, noise ``noise_std``).
    Agent mode: nothing has run; the observation is zero.

    ## Episode End
    Termination: the design is committed (fixed mode: the first step; plan mode: the second; agent
    mode: the commit choice, or any step once ``budget`` experiments have run).  No truncation.  Committing with
    missing data runs the fixed procedure's missing experiments first (charged).  With ``design_step=True``
    (v2) a commit only completes the identification, at the commit action's amplitude, and returns
    it (reward 0, the observation's last entry ``design_step`` = 1, the design features filled in);
    the next step designs from its last component, whatever its choice, and ends the episode.
    With ``measured_observation=True`` (v3) a commit whose closed-loop step identifies no usable gain
    and ``T_ar`` is a failed experiment (charged, counted in ``failed_experiments``, reward 0, info
    ``identified=False``): the episode goes on while the budget lasts, else it terminates without a
    design at cost 26 (``NO_DESIGN_COST``, that of an unstable loop).  An identification without the
    model the design reads is a failed identification too (the FPPI's FOPDT model needs an open-loop
    step or ramp that settles, which a drift or a load can prevent; the experiment counts as failed):
    the fixed mode draws another plant, as when its closed-loop steps fail, up to 10 plants (a given
    plant, or the tenth drawn: with ``measured_observation=True`` an episode that ends without a design,
    else a ``ValueError`` or, after ten draws, a ``RuntimeError``); the
    plan and agent modes treat it as a commit that identifies nothing (v0-v2: a ``ValueError``).

    ## Arguments
    | argument          | default                     | meaning                                                  |
    |-------------------|-----------------------------|----------------------------------------------------------|
    | `experiments`     | `"fixed"`                   | `"fixed"`, `"agent"` or `"plan"` (Action Space)           |
    | `family`          | see class                   | plant family of :mod:`envs.systems.families`                     |
    | `family_config`   | `None`                      | the family's config dataclass (its parameter ranges)      |
    | `noise_std`       | `0.01`                      | measurement noise, relative to a unit output change       |
    | `constraints`     | see class                   | :class:`envs.analysis.scoring.Constraints` or a dict of its fields |
    | `weights`         | `CostWeights()` (1, 1, 0.01, 0) | :class:`envs.analysis.scoring.CostWeights` or a dict: `load`, `setpoint`, `experiment` (per `T_ar` of experiment), `production` (per unit of `D_exp/T_ar`) |
    | `budget`          | `4`                         | experiments per episode (agent mode)                      |
    | `excursion_limit` | `5.0`                       | output limit that stops an experiment (agent mode)        |
    | `render_mode`     | `None`                      | `"rgb_array"`: `render()` draws the experiments and the loop |
    | `action`          | `"parameter"` (v1: `"residual"`) | the design parameter's coordinate: `"parameter"`, log scale over the range; `"residual"`, log-linear from the range's ends to the base rule's ``p_0`` at 0; `"robustness"`, the ``Ms`` (delay margin for the MSP) of the loop on the model (:mod:`envs.base_design`) |
    | `design_features` | `False` (v1: `True`)        | append ``log10 p_0`` and the base design's ``Ms`` and delay margin on the other identified model (:mod:`envs.base_design`) |
    | `identification`  | `"seeds"`                   | `"least-squares"` (not the MSP): fixed mode designs from the least-squares fit (Marlin 6.4) of the fixed procedure's open-loop step; agent mode adds a PRBS fitted by least squares, and the latest model experiment decides (:mod:`envs.episode_options`) |
    | `amplitude_limit` | `None` (none)               | largest experiment amplitude (output units, > 0): agent amplitudes are cut to it, the fixed procedure's experiments run at `min(1, limit)` |
    | `design_step`     | `False` (v2: `True`)        | agent mode: the commit completes and shows the identification (at the commit's amplitude), and a separate last step designs (Episode End) |
    | `violation_cost`  | `"graded"` (v3: `"bounded"`) | how a violating design is charged (Rewards; :func:`envs.analysis.scoring.violation_cost`) |
    | `measured_observation` | `False` (v3: `True`)   | the noise level estimated from the records (never the configured `noise_std`), failed experiments observed, and a failed commit charged instead of raised (Observation Space, Episode End) |
    | `plan`            | `None`                      | fixed mode: run the closed-loop step and the second experiment at these two amplitudes, as the plan mode's first step does (None: the procedure at amplitude 1 of the earlier versions) |
    | `experiment_set`  | `"all"` (v3: `"design"`)    | the agent mode's experiment types: all of the plant's kind, or those the design reads (Action Space) |
    | `discrete_action` | `False`                     | agent mode with `design_step`: a `Discrete` action with `action_masks()` instead of the `Box` (Action Space; :mod:`envs.discrete_action`) |
    | `disturbances`    | `None` (none)               | `{kind: level}` beyond the white noise, kinds `"drift"` (random walk, `level` per `sqrt(T_ar)`) and, for self-regulating plants, `"load"` (unmeasured input step during the experiment, `level` of output) (:mod:`envs.identification.disturbances`) |
    | `quantization`    | `0.0` (none)                | the sensor's resolution, in the units of `noise_std` (>= 0): every measured output of the experiments is floored to a multiple of it, as the TCLab's sensor (:func:`envs.identification.noise.sensor_reading`); the measured observation's noise estimate then knows the resolution (:func:`envs.identification.quantized_noise.quantized_noise_level`) |

    ``identification="seeds"`` is the identification of the source papers (the method of moments and the
    papers' formulas).  A bad value raises one ``ValueError`` naming the argument.

    ## Info
    At reset: ``plant`` (dict), ``features``.  On the final step: ``cost``, ``feasible``, ``score``
    (every figure of :class:`envs.analysis.scoring.Score`), ``plant``, ``model`` (identified), ``controller``,
    ``parameter`` (relative), ``experiment_time`` (in true ``T_ar``), ``features``; with a
    ``production`` weight also ``experiment_deviation`` (``D_exp`` in true ``T_ar``).  The wrapper
    ``agents.evaluation.oracle_info.OracleInfo`` adds ``oracle_cost`` and ``oracle_parameter``; the wrapper
    ``envs.tuning_env.ConstraintCost`` adds ``constraint_cost`` to every step's info, the violation as a
    constraint cost (as Safety Gym and Safety-Gymnasium expose it): 1.0 when the step ends the episode
    with a design that violates the constraints on the true plant, or with no design (``feasible``
    false), else 0.0 (0.0 on the agent mode's experiment steps).  Training against a limit on its mean:
    docs/lagrangian.md.

"""

VERSION_HISTORY = """
    ## Version History
    * v0: initial version.  The oracle's figures come from the wrapper ``OracleInfo`` (Info), not
      from an argument of the environment, so that ``envs`` imports nothing from ``baselines``.
    * v1: ``action="residual"`` and ``design_features=True``: the action is a bounded
      log-correction of the structure's base rule (``gorez-klan-mu-2``, ``fppi-eq34``, ``msp-eq50``;
      action 0 is the rule), and the observation ends with three design features.  Plants,
      experiments, dynamics and cost are v0's.
    * v2: v1 with a price on production: ``weights={"production": 0.05}`` (each unit of
      ``D_exp/T_ar``, the experiments' integrated output deviation, costs 0.05: the fixed procedure
      at amplitude 1 costs about 0.5 more than in v1) and ``amplitude_limit=3`` (agent-mode
      amplitudes above 3 are cut to 3).  The fixed mode runs v1's experiments (the same
      identifications); its cost adds the production term.  Agent mode has ``design_step=True``:
      the commit completes the identification at its own amplitude and the design is a step of its
      own, which sees the identification and the design features (in v1 the commit's design was
      chosen before the missing experiments ran, and its features were zero).  In agent mode the
      FPPI base rule reads an unmeasured mismatch area as 0 (:func:`envs.base_design.base_parameter`).
    * v3: v2 with ``violation_cost="bounded"`` (a violating design costs ``21 + 5 g/(1 + g)``, an
      unstable loop 26: bounded, and no stable loop above an unstable one; v2's ``21 + g`` reached the
      thousands near instability) and ``measured_observation=True`` (the noise ratio and the relay's
      hysteresis from the noise level estimated in the closed-loop step's record, not the configured
      one; the feature ``failed_experiments``; a commit that identifies nothing is a failed experiment,
      never an exception), and ``experiment_set="design"`` (agent mode offers only the experiments
      the structure's design reads).  Plants, the fixed mode's experiments and feasible costs are v2's (the
      relay's hysteresis follows the estimate).  The ``"plan"`` mode is new in every version.
    * Every version with ``design_step`` in agent mode (v2, v3): the option ``discrete_action=True``,
      a ``Discrete`` action with ``action_masks()`` whose indices are ``Box`` actions (Action Space);
      without it every episode is unchanged.
"""

PID_DESCRIPTION = """Gorez-Klan PID on self-regulating plants with dead time: choose ``mu``.

    ## Description
    A self-regulating plant ``K G(s) e^{-Ls}`` is identified by experiments; the SOPDT model of the
    method of moments (Gorez-Klan eq. 2-8) gives the series PID ``T_i = T_1``, ``T_d = T_2``,
    ``K_i = 1/(mu K D_2)`` (eq. 3-11, derivative filter ``T_d/10``), and the agent chooses ``mu``
    over [0.3, 300] (log scale).  The loop is then closed around the TRUE plant and scored.  Model
    mismatch is the point: on an FOPDT plant the SOPDT model invents a second lag, and the table's
    ``mu`` of 1.3 to 3 (Gorez-Klan table 3-1) can break ``Ms <= 2``.  When the moments see no dead
    time (``D_2 = 0``, plants with a strong lead) eq. 3-11 is undefined; :func:`envs.design.pid_design`
    floors ``D_2`` at 1% of ``T_ar``, which changes no design whose model has a larger dead time.

    Default family ``"stable"``: FOPDT, SOPDT and lag-chain plants in equal shares
    (:mod:`envs.systems.families`; also ``fopdt``, ``sopdt``, ``lag-chain`` and ``benchmark``); the
    held-out validation and test sets are fixed (:mod:`envs.systems.plant_sets`).  Default
    constraints ``Ms <= 2``, delay margin ``>= 0.2 L``.

    The residual action's base rule is ``gorez-klan-mu-2`` (``p_0 = 2``); ``action="robustness"``
    chooses the target ``Ms`` of the loop on the model, from 2.4 to 1.2, and solves for ``mu``.  The
    design features check the PID, designed on the SOPDT model, on its loop around the FOPDT model.
"""

FPPI_DESCRIPTION = """Hagglund's filtered predictive PI on self-regulating plants: choose ``T_r/T_n``.

    ## Description
    The FOPDT model ``K_n, T_n, L_n`` of the open-loop step (Ingimundarson eq. 11) gives the FPPI
    with ``T_i = T_n``, ``kappa = T_n/T_r`` and the robustness filter ``T_f = T_r``
    (Ingimundarson section 4); the agent chooses ``T_r/T_n`` over [0.001, 10] (log scale).  The
    mismatch area ``T_f_bar/T_n`` (eq. 22) is observed: it is what eq. 28-29 tune from, and what
    makes ``fppi-eq34`` hard to beat.

    Default family ``"stable"`` (also ``fopdt``, ``sopdt``, ``lag-chain`` and ``benchmark``); default
    constraints ``Ms <= 2``, delay margin ``>= 0.2 L``.

    The residual action's base rule is ``fppi-eq34`` (``p_0`` its ``T_r/T_n`` for the episode's
    identification); ``action="robustness"`` chooses the target ``Ms`` of the loop on the model, from
    2.4 to 1.2, and solves for ``T_r``.  The design features check the FPPI, designed on the FOPDT
    model, on its loop around the SOPDT model.
"""

MSP_DESCRIPTION = """Modified Smith predictor on integrating plants: choose ``T_r/L_n``.

    ## Description
    The two-parameter model ``K_n e^{-L_n s}/s`` of the closed-loop step gives the MSP with
    ``K_0 = 1/(2 L_n K_n)`` and ``K_r = 1/(K_n T_r)`` (Ingimundarson section 5, eq. 36-38); the
    agent chooses ``T_r/L_n`` over [0.01, 30] (log scale).  The pulse area ``A`` (eq. 46) is
    observed: it is what eq. 43 tunes from.

    Default family ``"integrating"``: plants with one integrator (:mod:`envs.systems.families`; also
    ``benchmark``); the held-out validation and test sets are fixed (:mod:`envs.systems.plant_sets`).
    Default constraints: delay margin ``>= 0.2 L`` only, no
    ``Ms`` bound.  The MSP's own loop (eq. 47) has ``Ms`` of 2.2 to 2.4 for ``T_r/L_n <= 1`` even
    with a perfect model, so ``Ms <= 2`` would rule out every tuning rule of the paper (eq. 43,
    eq. 50, ``T_r = T_n``) and push every design to ``T_r/L_n`` of about 2.3; the delay margin is
    the robustness measure of Ingimundarson's own analysis (eq. 40).

    The residual action's base rule is ``msp-eq50`` (``p_0`` its ``T_r/L_n`` for the episode's
    identification); ``action="robustness"`` chooses the target delay margin of the loop on the model,
    from 0.1 to 1.5 ``L_n``, and solves for ``T_r``.  The design features check the MSP, designed on
    the two-parameter model, on its loop around the integrator with the closed-loop step's lag,
    ``K_n e^{-(L_n - T_n) s}/(s (T_n s + 1))``.
"""

PI_DESCRIPTION = """Skogestad's SIMC PI on self-regulating plants: choose ``tau_c/theta``.

    ## Description
    The FOPDT model ``K_n e^{-L_n s}/(T_n s + 1)`` of the open-loop step (Ingimundarson eq. 11)
    gives the SIMC PI ``K_c = T_n/(K_n (tau_c + theta))``, ``T_i = min(T_n, 4 (tau_c + theta))``
    (S. Skogestad, "Simple analytic rules for model reduction and PID controller tuning",
    J. Process Control 13 (2003) 291-309; :func:`envs.design.simc_pi_gains`, the formula of the rule
    ``simc-pi`` too), ``theta = L_n`` floored at ``0.01 T_ar`` (a model without dead time); the agent chooses the closed-loop
    time constant ``tau_c`` as ``tau_c/theta`` over [0.03, 300] (log scale).  SIMC's own rule
    ``tau_c = theta`` ("tight" tuning) is ``simc-pi``, the strongest rule on these plants and the
    residual action's base: action 0 designs ``simc-pi``'s controller, bit for bit.  The loop is then
    closed around the TRUE plant and scored.

    The range: on 200 training plants (seeds 100000-100199, fixed mode) the oracle's ``tau_c/theta``
    searched over [0.001, 1000] has quantiles 1% 0.146, 5% 0.329, 25% 0.511, 50% 0.657, 75% 0.682,
    95% 1.80, 99% 80.0
    and lies in [0.079, 104]; the top 2.5% are plants whose open-loop step shows no dead time
    (``theta`` is the floor, and ``tau_c`` of about ``T_ar``).  The range leaves a factor of 2.6
    below and 2.9 above.

    Only ``-v3`` is registered, with the other structures' ``-v3`` arguments (residual action and
    design features, production priced, amplitude limit 3, a design step, bounded violation cost,
    measured observation; agent mode's experiments: closed-loop step and open-loop step).  The
    design features check the base design on the SOPDT model (Gorez-Klan eq. 2-8).

    Default family ``"stable"``: FOPDT, SOPDT and lag-chain plants in equal shares, those of
    ``PID-v3`` (:mod:`envs.systems.families`; also ``fopdt``, ``sopdt``, ``lag-chain`` and
    ``benchmark``); the held-out validation and test sets are fixed (:mod:`envs.systems.plant_sets`).
    Default constraints ``Ms <= 2``, delay margin ``>= 0.2 L``.

    The residual action's base rule is ``simc-pi`` (``p_0 = tau_c/theta = 1``); ``action="robustness"``
    chooses the target ``Ms`` of the loop on the model, from 2.4 to 1.2, and solves for ``tau_c``.
"""

PI_VERSION_HISTORY = """
    ## Version History
    * v3: initial version: the structure ``pi`` (:mod:`envs.structures`) in the ``-v3`` regime of
      the other structures (Arguments).  Plants, experiments and cost are ``PID-v3``'s.
"""
