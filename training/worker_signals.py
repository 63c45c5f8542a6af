"""Imported for its effect, by the fork server that starts the training workers, before the server
starts serving (``set_forkserver_preload`` in
:func:`sphere_env.training.vec_env._worker_start_method`, which both vector envs of worker processes
call).

Every process the fork server forks starts with the SIGINT disposition the server had when its
loop began, and a training worker then spends seconds unpickling its envs (importing torch, SB3 and
Drake) before its own code can ignore Ctrl-C. With the server ignoring SIGINT here, a worker
ignores it from its first instruction: a Ctrl-C to the process group during that start-up reaches
the training process alone, which stops its workers itself, and no worker prints a
KeyboardInterrupt.
"""

import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)
