"""The simulated world: one model of the robot, its sensors, the overhead camera and the faults, pure and seeded."""
