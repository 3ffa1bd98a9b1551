//! Command-line parsing shared by the onboard program (`heli-vehicle`) and the workstation's
//! `heli`: how their options take their values. What each option means is in [`crate::cli`]
//! and the workstation's commands.

/// `command` with every option of it and of its subcommands taking a negative number as its
/// value, so that `--speed -3` reaches the option's own check (which names the option and
/// its range) instead of clap's "unexpected argument '-3' found", which names neither.
pub fn negative_numbers(command: clap::Command) -> clap::Command {
    command
        .mut_args(|arg| {
            // Only an option that takes a value may (a flag with it fails clap's checks).
            if arg.get_action().takes_values() {
                arg.allow_negative_numbers(true)
            } else {
                arg
            }
        })
        .mut_subcommands(negative_numbers)
}

/// Parses the process's arguments into `T` with [`negative_numbers`]; on an error, prints
/// clap's message and exits as clap does (2; 0 for `--help` and `--version`).
pub fn parse<T: clap::Parser>() -> T {
    let matches = negative_numbers(T::command()).get_matches();
    T::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(clap::Parser, Debug)]
    struct Top {
        #[arg(long)]
        speed: Option<f64>,
        #[arg(long)]
        json: bool,
        #[command(subcommand)]
        sub: Option<Sub>,
    }

    #[derive(clap::Subcommand, Debug)]
    enum Sub {
        Trim {
            #[arg(long)]
            duration: f64,
        },
    }

    fn parse_from(words: &[&str]) -> Result<Top, clap::Error> {
        let matches = negative_numbers(<Top as clap::CommandFactory>::command())
            .try_get_matches_from(words)?;
        <Top as clap::FromArgMatches>::from_arg_matches(&matches)
    }

    #[test]
    fn a_negative_value_reaches_its_option_in_a_command_and_its_subcommands() {
        let top = parse_from(&["t", "--speed", "-3", "trim", "--duration", "-1.5"]).unwrap();
        assert_eq!(top.speed, Some(-3.0));
        assert!(matches!(top.sub, Some(Sub::Trim { duration }) if duration == -1.5));
        // An unknown flag is still one.
        let e = parse_from(&["t", "--speed", "1", "-x"]).unwrap_err();
        assert!(e.to_string().contains("unexpected argument '-x'"), "{e}");
        let top = parse_from(&["t", "--json"]).unwrap();
        assert!(top.json);
    }

    /// Every argument of `command` and its subcommands that takes no value is left without
    /// negative numbers (clap's own check of this runs only in debug builds, and panics).
    fn flags_untouched(command: &clap::Command) {
        for arg in command.get_arguments() {
            assert!(
                arg.get_action().takes_values() || !arg.is_allow_negative_numbers_set(),
                "{}: a flag given negative numbers",
                arg.get_id()
            );
        }
        command.get_subcommands().for_each(flags_untouched);
    }

    #[test]
    fn flags_are_left_as_they_are_in_the_onboard_programs_commands() {
        use clap::{Args, CommandFactory, Subcommand};
        flags_untouched(&negative_numbers(<Top as CommandFactory>::command()));
        let onboard = crate::cli::BootstrapCommand::augment_subcommands(
            crate::cli::BootstrapArgs::augment_args(clap::Command::new("heli-vehicle")),
        );
        let onboard = negative_numbers(onboard);
        flags_untouched(&onboard);
        // And clap's own checks pass (they run in a debug build).
        onboard.debug_assert();
    }
}
