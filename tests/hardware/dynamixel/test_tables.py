"""Each model's control table against the ROBOTIS e-Manual's (the oracle below: address,
size, register, access, initial value, range), and the emulator enforcing what the table says:
value lists (Data Range Error), the indirect blocks.

The rows are the e-Manual's control tables, copied by hand from the e-Manual's sources
(github.com/ROBOTIS-GIT/emanual, docs/en/dxl/x/<model>.md; the page is
https://emanual.robotis.com/docs/en/dxl/x/<model>/). Range forms: ``a~b``; ``list:`` the
values the description allows; ``bits:`` the Drive Mode bits the description allows (every
combination); ``limit:`` the registers the range names; ``-``: none given. Where a row is not
the page's range column, the comment says why:

* Secondary ID: the column reads 0 ~ 252, but 253..255 switch it off (255 is the initial
  value); the servo takes them.
* Bus Watchdog: the column reads 1 ~ 127; 0 switches it off (the description).
* Drive Mode: the description's bit list (_includes/en/dxl/x/drive_mode.md), not the older
  range columns (XM430 page 0 ~ 1, XM540 page 0 ~ 5).
* Indirect Address n / Data n (n = 1..56): the e-Manual lists the first and last three of each
  block with an ellipsis; the rows are generated from them (:func:`indirect_rows`).
"""

from __future__ import annotations

import pytest

from inkarm.hardware.dynamixel import protocol as p
from inkarm.hardware.dynamixel.tables import EEPROM, RAM, table

# https://emanual.robotis.com/docs/en/dxl/x/xm430-w350/ (emanual docs/en/dxl/x/xm430-w350.md
# at 08551725). That page's ID range reads 0 ~ 253 and its Voltage Limit range 110 ~ 300 (it
# would refuse its own defaults 160/95): 0 ~ 252 and 95 ~ 160 as every other X-series 12 V
# page. Startup Configuration (60) and Backup Ready (147), firmware 45, are on the XL430 and
# XM540 pages, not yet on this one. No Acceleration Limit (40): the pre-firmware-42 tables
# (and LeRobot's, copied from them) have one with Velocity Limit 350.
XM430_W350 = """
0   2 model_number            R  1020 -
2   4 model_information       R  -    -
6   1 firmware_version        R  -    -
7   1 id                      RW 1    0~252
8   1 baud_rate               RW 1    0~7
9   1 return_delay_time       RW 250  0~254
10  1 drive_mode              RW 0    bits:0,2,3
11  1 operating_mode          RW 3    list:0,1,3,4,5,16
12  1 secondary_id            RW 255  0~255
13  1 protocol_type           RW 2    1~2
20  4 homing_offset           RW 0    -1044479~1044479
24  4 moving_threshold        RW 10   0~1023
31  1 temperature_limit       RW 80   0~100
32  2 max_voltage_limit       RW 160  95~160
34  2 min_voltage_limit       RW 95   95~160
36  2 pwm_limit               RW 885  0~885
38  2 current_limit           RW 1193 0~1193
44  4 velocity_limit          RW 200  0~1023
48  4 max_position_limit      RW 4095 0~4095
52  4 min_position_limit      RW 0    0~4095
60  1 startup_configuration   RW 0    0~3
63  1 shutdown                RW 52   -
64  1 torque_enable           RW 0    0~1
65  1 led                     RW 0    0~1
68  1 status_return_level     RW 2    0~2
69  1 registered_instruction  R  0    0~1
70  1 hardware_error_status   R  0    -
76  2 velocity_i_gain         RW 1920 0~16383
78  2 velocity_p_gain         RW 100  0~16383
80  2 position_d_gain         RW 0    0~16383
82  2 position_i_gain         RW 0    0~16383
84  2 position_p_gain         RW 800  0~16383
88  2 feedforward_2nd_gain    RW 0    0~16383
90  2 feedforward_1st_gain    RW 0    0~16383
98  1 bus_watchdog            RW 0    0~127
100 2 goal_pwm                RW -    limit:pwm_limit
102 2 goal_current            RW -    limit:current_limit
104 4 goal_velocity           RW -    limit:velocity_limit
108 4 profile_acceleration    RW 0    0~32767
112 4 profile_velocity        RW 0    0~32767
116 4 goal_position           RW -    limit:min_position_limit,max_position_limit
120 2 realtime_tick           R  -    0~32767
122 1 moving                  R  0    0~1
123 1 moving_status           R  0    -
124 2 present_pwm             R  -    -
126 2 present_current         R  -    -
128 4 present_velocity        R  -    -
132 4 present_position        R  -    -
136 4 velocity_trajectory     R  -    -
140 4 position_trajectory     R  -    -
144 2 present_input_voltage   R  -    -
146 1 present_temperature     R  -    -
147 1 backup_ready            R  -    0~1
"""

# https://emanual.robotis.com/docs/en/dxl/x/xl430-w250/ (emanual docs/en/dxl/x/xl430-w250.md
# at 00a4b781): no Current Limit (38) or Goal Current (102); operating modes from
# _includes/en/dxl/x/operating_mode_xl.md (velocity, position, extended position, PWM).
XL430_W250 = """
0   2 model_number            R  1060 -
2   4 model_information       R  -    -
6   1 firmware_version        R  -    -
7   1 id                      RW 1    0~252
8   1 baud_rate               RW 1    0~7
9   1 return_delay_time       RW 250  0~254
10  1 drive_mode              RW 0    bits:0,2,3
11  1 operating_mode          RW 3    list:1,3,4,16
12  1 secondary_id            RW 255  0~255
13  1 protocol_type           RW 2    1~2
20  4 homing_offset           RW 0    -1044479~1044479
24  4 moving_threshold        RW 10   0~1023
31  1 temperature_limit       RW 72   0~100
32  2 max_voltage_limit       RW 140  60~140
34  2 min_voltage_limit       RW 60   60~140
36  2 pwm_limit               RW 885  0~885
44  4 velocity_limit          RW 265  0~1023
48  4 max_position_limit      RW 4095 0~4095
52  4 min_position_limit      RW 0    0~4095
60  1 startup_configuration   RW 0    0~3
63  1 shutdown                RW 52   -
64  1 torque_enable           RW 0    0~1
65  1 led                     RW 0    0~1
68  1 status_return_level     RW 2    0~2
69  1 registered_instruction  R  0    0~1
70  1 hardware_error_status   R  0    -
76  2 velocity_i_gain         RW 1000 0~16383
78  2 velocity_p_gain         RW 100  0~16383
80  2 position_d_gain         RW 4000 0~16383
82  2 position_i_gain         RW 0    0~16383
84  2 position_p_gain         RW 640  0~16383
88  2 feedforward_2nd_gain    RW 0    0~16383
90  2 feedforward_1st_gain    RW 0    0~16383
98  1 bus_watchdog            RW 0    0~127
100 2 goal_pwm                RW -    limit:pwm_limit
104 4 goal_velocity           RW -    limit:velocity_limit
108 4 profile_acceleration    RW 0    0~32767
112 4 profile_velocity        RW 0    0~32767
116 4 goal_position           RW -    limit:min_position_limit,max_position_limit
120 2 realtime_tick           R  -    0~32767
122 1 moving                  R  0    0~1
123 1 moving_status           R  0    -
124 2 present_pwm             R  -    -
126 2 present_load            R  -    -1000~1000
128 4 present_velocity        R  -    -
132 4 present_position        R  -    -
136 4 velocity_trajectory     R  -    -
140 4 position_trajectory     R  -    -
144 2 present_input_voltage   R  -    -
146 1 present_temperature     R  -    -
147 1 backup_ready            R  -    0~1
"""

# https://emanual.robotis.com/docs/en/dxl/x/xm540-w270/ (emanual docs/en/dxl/x/xm540-w270.md
# at 028a13d2)
XM540_W270 = """
0   2 model_number            R  1120 -
2   4 model_information       R  -    -
6   1 firmware_version        R  -    -
7   1 id                      RW 1    0~252
8   1 baud_rate               RW 1    0~7
9   1 return_delay_time       RW 250  0~254
10  1 drive_mode              RW 0    bits:0,1,2,3
11  1 operating_mode          RW 3    list:0,1,3,4,5,16
12  1 secondary_id            RW 255  0~255
13  1 protocol_type           RW 2    1~2
20  4 homing_offset           RW 0    -1044479~1044479
24  4 moving_threshold        RW 10   0~1023
31  1 temperature_limit       RW 80   0~100
32  2 max_voltage_limit       RW 160  95~160
34  2 min_voltage_limit       RW 95   95~160
36  2 pwm_limit               RW 885  0~885
38  2 current_limit           RW 2047 0~2047
44  4 velocity_limit          RW 128  0~1023
48  4 max_position_limit      RW 4095 0~4095
52  4 min_position_limit      RW 0    0~4095
56  1 external_port_mode_1    RW 3    0~3
57  1 external_port_mode_2    RW 3    0~3
58  1 external_port_mode_3    RW 3    0~3
60  1 startup_configuration   RW 0    0~3
63  1 shutdown                RW 52   -
64  1 torque_enable           RW 0    0~1
65  1 led                     RW 0    0~1
68  1 status_return_level     RW 2    0~2
69  1 registered_instruction  R  0    0~1
70  1 hardware_error_status   R  0    -
76  2 velocity_i_gain         RW 1920 0~16383
78  2 velocity_p_gain         RW 100  0~16383
80  2 position_d_gain         RW 0    0~16383
82  2 position_i_gain         RW 0    0~16383
84  2 position_p_gain         RW 800  0~16383
88  2 feedforward_2nd_gain    RW 0    0~16383
90  2 feedforward_1st_gain    RW 0    0~16383
98  1 bus_watchdog            RW 0    0~127
100 2 goal_pwm                RW -    limit:pwm_limit
102 2 goal_current            RW -    limit:current_limit
104 4 goal_velocity           RW -    limit:velocity_limit
108 4 profile_acceleration    RW 0    0~32767
112 4 profile_velocity        RW 0    0~32767
116 4 goal_position           RW -    limit:min_position_limit,max_position_limit
120 2 realtime_tick           R  -    0~32767
122 1 moving                  R  0    0~1
123 1 moving_status           R  0    -
124 2 present_pwm             R  -    -
126 2 present_current         R  -    -
128 4 present_velocity        R  -    -
132 4 present_position        R  -    -
136 4 velocity_trajectory     R  -    -
140 4 position_trajectory     R  -    -
144 2 present_input_voltage   R  -    -
146 1 present_temperature     R  -    -
147 1 backup_ready            R  -    0~1
152 2 external_port_data_1    RW -    -
154 2 external_port_data_2    RW -    -
156 2 external_port_data_3    RW -    -
"""

PUBLISHED = {"XM430-W350": XM430_W350, "XL430-W250": XL430_W250, "XM540-W270": XM540_W270}


def indirect_rows() -> dict[str, tuple]:
    """Indirect Address n at 168 + 2(n-1) (n <= 28) or 578 + 2(n-29), initially its Indirect
    Data's address, 64 ~ 661; Indirect Data n at 224 + (n-1) or 634 + (n-29), 0 ~ 255."""
    rows = {}
    for n in range(1, 57):
        address, data = (168 + 2 * (n - 1), 224 + n - 1) if n <= 28 else \
            (578 + 2 * (n - 29), 634 + n - 29)
        rows[f"indirect_address_{n}"] = (address, 2, "RW", str(data), "64~661")
        rows[f"indirect_data_{n}"] = (data, 1, "RW", "0", "0~255")
    return rows


def published(model: str) -> dict[str, tuple]:
    rows = {}
    for line in PUBLISHED[model].strip().splitlines():
        address, size, name, access, initial, bounds = line.split()
        rows[name] = (int(address), int(size), access, initial, bounds)
    return rows | indirect_rows()


@pytest.mark.parametrize("model", sorted(PUBLISHED))
def test_the_control_table_is_the_published_one(model):
    expected = published(model)
    t = table(model)
    assert sorted(r.name for r in t.registers) == sorted(expected)
    for reg in t.registers:
        address, size, access, initial, bounds = expected[reg.name]
        assert (reg.address, reg.size, reg.access) == (address, size, access), reg.name
        assert reg.area == (EEPROM if address < 64 else RAM), reg.name
        if initial != "-":
            assert reg.default == int(initial), reg.name
        kind, _, rest = bounds.rpartition(":")
        if kind == "list":
            assert reg.values == tuple(int(v) for v in rest.split(",")), reg.name
        elif kind == "bits":
            mask = sum(1 << int(b) for b in rest.split(","))
            assert reg.values == tuple(v for v in range(256) if not v & ~mask), reg.name
        elif kind == "limit":
            assert reg.limit == tuple(rest.split(",")), reg.name
        elif bounds != "-":
            low, high = (int(v) for v in bounds.split("~"))
            assert (reg.minimum, reg.maximum, reg.values) == (low, high, ()), reg.name


OK = 0  # COMM_SUCCESS


@pytest.mark.hardware_emulated
def test_a_value_off_the_list_is_a_data_range_error_as_on_a_servo(sdk_port, emulator):
    port, ph = sdk_port  # servos 1 XM430-W350, 2 XL430-W250, 3 XM540-W270, torque off
    assert ph.write1ByteTxRx(port, 1, 11, 2) == (OK, p.DATA_RANGE_ERROR)  # no mode 2
    assert ph.write1ByteTxRx(port, 2, 11, 0) == (OK, p.DATA_RANGE_ERROR)  # XL430: no current
    assert ph.write1ByteTxRx(port, 2, 11, 5) == (OK, p.DATA_RANGE_ERROR)
    assert ph.write1ByteTxRx(port, 2, 11, 16) == (OK, 0)                  # PWM it has
    assert ph.write1ByteTxRx(port, 1, 10, 2) == (OK, p.DATA_RANGE_ERROR)  # leader/follower:
    assert ph.write1ByteTxRx(port, 3, 10, 2) == (OK, 0)                   # X540 only
    assert ph.write1ByteTxRx(port, 1, 10, 13) == (OK, 0)
    assert ph.write1ByteTxRx(port, 1, 68, 3) == (OK, p.DATA_RANGE_ERROR)  # status return level
    assert ph.write1ByteTxRx(port, 1, 8, 8) == (OK, p.DATA_RANGE_ERROR)   # baud rate index
    assert ph.write1ByteTxRx(port, 2, 31, 101) == (OK, p.DATA_RANGE_ERROR)
    assert ph.write2ByteTxRx(port, 2, 32, 141) == (OK, p.DATA_RANGE_ERROR)  # XL430: 60..140
    assert ph.write2ByteTxRx(port, 2, 34, 60) == (OK, 0)
    assert [emulator.servo(i).memory.get("operating_mode") for i in (1, 2)] == [3, 16]
    assert ph.read2ByteTxRx(port, 2, 32) == (140, OK, 0)


@pytest.mark.hardware_emulated
def test_indirect_data_reads_and_writes_the_register_its_address_names(sdk_port, emulator):
    port, ph = sdk_port
    assert ph.read2ByteTxRx(port, 1, 168) == (224, OK, 0)   # at first: its own data byte
    assert ph.write1ByteTxRx(port, 1, 224, 7) == (OK, 0)
    assert ph.read1ByteTxRx(port, 1, 224) == (7, OK, 0)
    for k in range(4):  # Indirect Address 1..4 := Goal Position's four bytes
        assert ph.write2ByteTxRx(port, 1, 168 + 2 * k, 116 + k) == (OK, 0)
    assert ph.write4ByteTxRx(port, 1, 224, 2500) == (OK, 0)
    assert emulator.servo(1).memory.get("goal_position") == 2500
    assert ph.read4ByteTxRx(port, 1, 224) == (2500, OK, 0)
    assert ph.write1ByteTxRx(port, 1, 224, 1) == (OK, p.DATA_LENGTH_ERROR)  # a quarter of it
    assert ph.write2ByteTxRx(port, 1, 170, 20) == (OK, p.DATA_RANGE_ERROR)  # EEPROM: 64..661
    assert ph.write2ByteTxRx(port, 1, 578, 147) == (OK, 0)  # Indirect Address 29 := 147
    assert ph.write2ByteTxRx(port, 1, 580, 64) == (OK, 0)   # Indirect Address 30 := 64
    assert ph.write1ByteTxRx(port, 1, 635, 1) == (OK, 0)    # Torque Enable, through Data 30
    assert emulator.servo(1).memory.get("torque_enable") == 1
    assert ph.read1ByteTxRx(port, 1, 634) == (0, OK, 0)     # Backup Ready, through Data 29
    assert ph.write1ByteTxRx(port, 1, 634, 1) == (OK, p.ACCESS_ERROR)  # read-only through it
    assert ph.write2ByteTxRx(port, 1, 582, 132) == (OK, 0)  # Indirect Address 31 := 132
    assert ph.write1ByteTxRx(port, 1, 636, 1) == (OK, p.DATA_LENGTH_ERROR)  # 1 of 4 bytes
    # the limits still hold through it: Goal Position outside the position limits
    assert ph.write4ByteTxRx(port, 1, 224, 5000) == (OK, p.DATA_LIMIT_ERROR)
