"""The robot's know-how as async plans: atomic actions, pick and place, search / fetch /
deliver / transport, and the table-setting demo. Depends on :mod:`executive` and :mod:`cpl`
only, never on :mod:`projection` internals."""
