"""What every test process needs, whoever started it."""

from __future__ import annotations

import signal

# A process started in the background by a shell without job control ignores Ctrl-C, and passes
# that on to every program it starts: the tests that stop a run or a server with SIGINT would
# then wait for it in vain. Ctrl-C is given back its usual meaning, here and so in the children.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
