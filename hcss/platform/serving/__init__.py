"""How the platform runs as server processes: waitress with its bounds (`connections`),
a group of processes (`workers`) behind nginx (`nginx`), what a running server tells the
other commands (`announce`), and one server in its own process for tests and the
benchmark (`localserver`)."""
