"""rwhonet.libraries: a signal inside ``interruptible`` stops the command, also where a C
library lost the exception its handler raised."""

import os
import signal

import pytest

from rwhonet.libraries import Interrupted, interruptible, raise_if_interrupted


def lose_a_signal(signum: int) -> None:
    """What numpy's np.char.mod did with the handler's exception: dropped it."""
    try:
        os.kill(os.getpid(), signum)
        signal.raise_signal(signum)  # not reached: the handler raised on the kill already
    except Interrupted:
        pass


def test_a_lost_interrupt_is_raised_again_where_a_loop_checks():
    with interruptible():
        raise_if_interrupted()  # nothing came: nothing raised
        lose_a_signal(signal.SIGTERM)
        with pytest.raises(Interrupted) as err:
            raise_if_interrupted()
        assert err.value.signum == signal.SIGTERM
        with pytest.raises(Interrupted):  # and again, until the command has unwound
            raise_if_interrupted()


def test_a_later_command_does_not_inherit_an_earlier_interrupt():
    with interruptible():
        lose_a_signal(signal.SIGHUP)
    raise_if_interrupted()  # outside the block: nothing to raise
    with interruptible():
        raise_if_interrupted()
