"""The stand-in's physics, by stage: the world (``world``) and its robots (``robot``, ``motors``,
``nao_model``), the per-cycle step (``stepper``), collision (``collision``), the maximal bodies
(``bodies``), constraint rows (``rows``), solvers (``solver``), integration (``integrate``), one
robot's step and an island's (``robot_step``, ``tree_step``, ``island_step``), the small linear
algebra they share (``linalg``, ``rotations``), contacts as the sensors read them (``contact``),
and the calibration walk's replay (``calibration_walk``)."""
