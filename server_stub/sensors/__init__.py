"""What the stand-in tells its clients: perceptions (joints, IMU, FRP, vision, hearing) and the
monitor stream, as text in the real server's formats."""
