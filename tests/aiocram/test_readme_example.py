import cpl
from aiocram.testing import assert_retried
from executive import NavigationPoseUnreachable, Pose, a, perform


async def go_to_table() -> None:
    going = a.motion(type="going", pose=Pose((1.0, 0.5, 0.0)))
    await cpl.with_retry(lambda: perform(going), on=NavigationPoseUnreachable, counter=3)


def test_go_to_table_retries_twice_then_arrives(cpl_run, fake_robot):
    unreachable = NavigationPoseUnreachable
    nav = fake_robot.add("navigation", fail_on={1: unreachable, 2: unreachable})
    cpl_run(fake_robot.run, go_to_table, name="go-to-table")
    assert_retried("go-to-table", "navigation", times=2)
    assert len(nav.calls) == 3 and len(nav.completed) == 1
