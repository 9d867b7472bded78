"""The stand-in's physics: the world, the robot (model, motors, slip), the two step backends
(Bullet, and the ODE-like ``ode_step``), pose maths, and the calibration walk's replay."""
