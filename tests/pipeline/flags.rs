//! One convention for the command line, checked on clap's command tree itself: every flag
//! that takes one of a fixed set of values lists them in `--help`; `--plot` takes a
//! directory on every command; an output file is `-o/--out` wherever a command writes one
//! main file; and every flag and command says what it does.

use clap::CommandFactory;
use contourcheck::cli::Cli;

fn subcommands() -> Vec<clap::Command> {
    let mut cli = Cli::command();
    cli.build();
    cli.get_subcommands().cloned().collect()
}

#[test]
fn enumerated_values_are_listed_in_help() {
    for mut cmd in subcommands() {
        let name = cmd.get_name().to_string();
        let help = cmd.render_long_help().to_string();
        for arg in cmd.get_arguments() {
            for value in arg.get_possible_values() {
                assert!(
                    help.contains(value.get_name()),
                    "{name} --{}: value `{}` not in --help",
                    arg.get_id(),
                    value.get_name()
                );
            }
        }
    }
    // The ones users asked for, by name.
    let listed = |cmd: &str, flag: &str| {
        subcommands()
            .into_iter()
            .find(|c| c.get_name() == cmd)
            .and_then(|c| {
                c.get_arguments()
                    .find(|a| a.get_id() == flag)
                    .map(|a| a.get_possible_values().len())
            })
            .unwrap_or(0)
    };
    assert_eq!(listed("synth", "effect"), 13, "every cause synth can hide");
    assert_eq!(listed("diagnose", "causes"), 13);
    assert_eq!(listed("diagnose", "exclude"), 13);
    assert_eq!(listed("bode", "axis"), 2);
    assert_eq!(listed("check", "profile"), 3);
}

#[test]
fn plot_is_a_directory_and_out_is_o_everywhere() {
    for cmd in subcommands() {
        for arg in cmd.get_arguments() {
            let id = arg.get_id().as_str();
            let value = arg.get_value_names().map(|v| {
                v.iter()
                    .map(|s| s.to_string())
                    .collect::<Vec<_>>()
                    .join(" ")
            });
            if id == "plot" {
                assert_eq!(value.as_deref(), Some("DIR"), "{} --plot", cmd.get_name());
            }
            if id == "out" {
                assert_eq!(arg.get_short(), Some('o'), "{} --out", cmd.get_name());
            }
        }
    }
}

#[test]
fn every_command_and_flag_says_what_it_does() {
    for cmd in subcommands() {
        assert!(
            cmd.get_about().is_some(),
            "{} has no description",
            cmd.get_name()
        );
        for arg in cmd.get_arguments() {
            if matches!(arg.get_id().as_str(), "help" | "version") {
                continue;
            }
            assert!(
                arg.get_help().is_some() || arg.get_long_help().is_some(),
                "{} --{} has no description",
                cmd.get_name(),
                arg.get_id()
            );
        }
    }
}
