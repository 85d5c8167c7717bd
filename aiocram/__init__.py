"""aiocram: CRAM's concurrent plan language (``cpl``) and plan executive on asyncio.

The plan language lives in :mod:`cpl`; the ``aiocram`` command line is :mod:`aiocram.cli`.
"""
