"""LcmChannels: defaults and partial YAML overrides."""

from heft.hardware_interface.channels import LcmChannels, derived_command_url
from pydrake.common.yaml import yaml_load_typed


def test_defaults_stay_on_this_machine_and_names_are_unique():
    channels = LcmChannels()
    assert channels.lcm_url.endswith("ttl=0")
    names = [c.name for c in (channels.master_state, channels.master_command, channels.slave_status,
                              channels.slave_command, channels.ft_sample)]
    assert len(set(names)) == len(names)


def test_yaml_overrides_one_field_and_keeps_the_rest():
    channels = yaml_load_typed(schema=LcmChannels, data="{ft_sample: {rate: 1000}}")
    assert channels.ft_sample.rate == 1000.0
    assert channels.ft_sample.name == LcmChannels().ft_sample.name
    assert channels.master_state == LcmChannels().master_state


def test_commands_go_one_port_up_unless_given():
    """The controller publishes where it does not listen: by default the same group one port up."""
    channels = LcmChannels()
    assert channels.command_lcm_url() == "udpm://239.255.76.67:7668?ttl=0"
    assert derived_command_url("udpm://239.255.76.67") == "udpm://239.255.76.67:7668"
    assert derived_command_url("memq://") == "memq://"
    given = LcmChannels(lcm_url="udpm://239.255.0.1:9000", command_url="udpm://239.255.0.2:9000")
    assert given.command_lcm_url() == "udpm://239.255.0.2:9000"
    assert yaml_load_typed(schema=LcmChannels, data="{lcm_url: 'udpm://239.255.0.1:9000'}").command_lcm_url() == (
        "udpm://239.255.0.1:9001")
