# bash completion for rs-discover (installed as
# /usr/share/bash-completion/completions/rs-discover).
# Commands and options come from rs-discover's own --help, so they never drift from
# the program; device ids and serials from the daemon (rs-discover list), asked
# without waiting for its first discovery so a Tab never hangs.

_rs_discover_daemon() {
    # The user's --endpoint, if the line has one, reaches the same daemon. `words`
    # and `cword` are _rs_discover's: the line split with ':' and '=' kept inside
    # words (COMP_WORDS has unix:/path as three words, unix : /path).
    local i endpoint=()
    for ((i = 1; i < cword; i++)); do
        case "${words[i]}" in
            --endpoint) endpoint=(--endpoint "${words[i + 1]}") ;;
            --endpoint=*) endpoint=("${words[i]}") ;;
        esac
    done
    timeout 2 rs-discover "${endpoint[@]}" list --no-wait-complete "$@" 2>/dev/null
}

_rs_discover() {
    local cur prev words cword
    # ':' and '=' do not split words here (both are in COMP_WORDBREAKS): an endpoint
    # such as unix:/run/x.sock or http://host:8035 stays one word.
    _init_completion -n =: || return

    local i command=""
    for ((i = 1; i < cword; i++)); do
        case "${words[i]}" in
            --endpoint | --color) ((i++)) ;;
            -*) ;;
            *) command="${words[i]}"; break ;;
        esac
    done

    if [[ -z $command ]]; then
        case "$prev" in
            --endpoint) return ;;
            --color) COMPREPLY=($(compgen -W "auto always never" -- "$cur")); return ;;
        esac
        if [[ $cur == -* ]]; then
            COMPREPLY=($(compgen -W "--endpoint --color --help --version" -- "$cur"))
        else
            local commands
            commands=$(rs-discover --help 2>/dev/null | awk '/^Commands:/ {on = 1; next} on && /^  [a-z]/ {print $1} on && /^$/ {on = 0}')
            COMPREPLY=($(compgen -W "$commands help" -- "$cur"))
        fi
        return
    fi

    case "$prev" in
        --source | -s) COMPREPLY=($(compgen -W "dds usb remote-usb" -- "$cur")); return ;;
        --color) COMPREPLY=($(compgen -W "auto always never" -- "$cur")); return ;;
        --serial) COMPREPLY=($(compgen -W "$(_rs_discover_daemon --format '{serial}')" -- "$cur")); return ;;
        --host) COMPREPLY=($(compgen -W "$(_rs_discover_daemon --source remote-usb --format '{host.name}' | sort -u)" -- "$cur")); return ;;
        --domain | -d | --product-line | -p | --name | -n | --address | -a | --format | -f | --timeout | -t | \
            --wait | --count | -c | --complete-timeout | --last-event-id | --endpoint)
            return ;;
    esac
    if [[ $cur == -* ]]; then
        local options
        options=$(rs-discover "$command" --help 2>/dev/null | grep -oE -- '--[a-z][a-z-]*' | sort -u)
        COMPREPLY=($(compgen -W "$options" -- "$cur"))
        return
    fi
    case "$command" in
        get | describe | clients | history | wait | doctor)
            # ids and serials of the cameras there now
            COMPREPLY=($(compgen -W "$(_rs_discover_daemon -q) $(_rs_discover_daemon --format '{serial}')" -- "$cur"))
            ;;
        help)
            COMPREPLY=($(compgen -W "$(rs-discover --help 2>/dev/null | awk '/^Commands:/ {on = 1; next} on && /^  [a-z]/ {print $1}')" -- "$cur"))
            ;;
    esac
}
complete -F _rs_discover rs-discover
