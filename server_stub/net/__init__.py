"""The stand-in's network side: the server loop (sockets, pacing, sync), its clients, agents'
effector commands and trainer commands."""
