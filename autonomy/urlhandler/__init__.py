"""pyserial URL handlers of our own: ``emu://`` (see :mod:`autonomy.urlhandler.protocol_emu`)."""
