-- A session with Struck in Ardour 7, headless (ardour7-lua, the dummy
-- backend). `create` makes a new session with a MIDI track playing
-- Struck.vst3, a chord and a scale on it and some parameters away from their
-- defaults (Ardour must read the 128 samples of latency load smoothing
-- reports), saves it and renders the track through Struck; `reopen` loads the
-- saved session as a user reopening it and renders it again. Both print the
-- parameters as Ardour reads them back ("params: ...") and where the render's
-- files are ("rendered: ..."), for the caller to compare.
--
-- The render is the track bounced through its instrument, which runs the
-- plugin as an export does, faster than real time, without Ardour 7.3's
-- freewheeling export (which corrupts its own heap now and then, with its own
-- synth too).
--
-- `automate` makes a session whose only note, C4 at 2 s, is struck at the
-- sample where the hammer's mass is automated from 0.6 to 1.7 (a step), saves
-- and renders it; `steady` the same with the mass at 1.7 throughout. A
-- bounce of the automated session (again when `reopen`ed) must be the
-- steady one's, sample for sample: the change is not late.
-- `automate-early` and `light-early` do the same with E4 struck at 1 s too,
-- the latter with the mass at 0.6 throughout: the two must be the same
-- samples until Ardour hands the change over (the change is not early).
--
-- usage: ardour7-lua struck_session.lua MODE SESSION_DIR RENDER_NAME
--   MODE: create, reopen, automate, steady, automate-early or light-early
-- environment: STRUCK_INSTRUMENT, the "Instrument" parameter's index (0-6).

local mode, session_dir, render_name = arg[1], arg[2], arg[3]
local SNAPSHOT = "struck"
local RATE = 48000
-- The latency Struck reports with load smoothing on (its default): 2.7 ms.
local LATENCY = 128
local LENGTH = 5 * RATE

local function say(...) print("struck-session:", ...) end

local function parameter_index(plugin, name)
  for i = 0, plugin:parameter_count() - 1 do
    if plugin:parameter_label(plugin:nth_parameter(i, true)) == name then return i end
  end
  error("Struck has no parameter " .. name)
end

-- Non-default values, in the parameters' own units.
local SETTINGS = {
  { "Instrument", tonumber(os.getenv("STRUCK_INSTRUMENT") or "0") },
  { "Hammer mass", 1.7 },
  { "Damping", 0.6 },
  { "Level", -6 },
  { "Stereo width", 0.5 },
}

local function print_params(processor)
  local plugin = processor:to_insert():plugin(0)
  local parts = {}
  for _, s in ipairs(SETTINGS) do
    local value = ARDOUR.LuaAPI.get_processor_param(processor, parameter_index(plugin, s[1]), true)
    parts[#parts + 1] = string.format("%s=%.5g", s[1], value)
  end
  say("params: " .. table.concat(parts, " "))
end

-- The plugin rebuilds its instrument for new settings on a thread of its
-- own while the engine runs (and Ardour hands it a reopened session's state
-- after activating it): a user renders some time after.
local function settle()
  ARDOUR.LuaAPI.wait_for_process_callback(4, 2000)
  sleep(3)
end

local function render(track)
  local region = track:bounce_range(0, LENGTH, ARDOUR.InterThreadInfo(), track:nth_plugin(0), true, render_name)
  assert(not region:isnil(), "the render failed")
  local audio = region:to_audioregion()
  for i = 0, audio:n_channels() - 1 do say("rendered: " .. region:source(i):to_filesource():path()) end
end

-- A C major chord held a second, then the scale in eighths at 120 bpm, at
-- velocities from soft to loud.
local NOTES = {}
for i, key in ipairs({ 60, 64, 67 }) do NOTES[#NOTES + 1] = { key, 70 + 15 * i, 0.0, 1.0 } end
for i, key in ipairs({ 60, 62, 64, 65, 67, 69, 71, 72 }) do
  local t = 1.0 + (i - 1) * 0.25
  NOTES[#NOTES + 1] = { key, 40 + 10 * i, t, t + 0.225 }
end

-- The automated step: at 2 s (on a beat at 120 bpm, so the session's
-- musical time holds it to the sample), where the one note is struck.
local STEP = 2 * RATE
local LIGHT, HEAVY = 0.6, 1.7

-- A new session with Struck on a MIDI track playing `notes`; the track.
local function new_session(notes)
  assert(create_session(session_dir, SNAPSHOT, RATE), "could not create the session")
  local info = ARDOUR.LuaAPI.new_plugin_info("Struck", ARDOUR.PluginType.VST3)
  assert(not info:isnil(), "Struck.vst3 is not in Ardour's plugin cache")
  local tracks = Session:new_midi_track(ARDOUR.ChanCount(ARDOUR.DataType("midi"), 1),
    ARDOUR.ChanCount(ARDOUR.DataType("audio"), 2), false, info, nil, nil, 1, "Struck",
    ARDOUR.PresentationInfo.max_order, ARDOUR.TrackMode.Normal, true)
  local track = tracks:front()
  local processor = track:nth_plugin(0)
  assert(not processor:isnil(), "Struck did not load")

  -- An empty MIDI region (the playlist bounced up to the instrument), added
  -- as a user's undoable command (which gives the session its range).
  local region = track:bounce_range(0, LENGTH, ARDOUR.InterThreadInfo(), processor, false, "notes")
  assert(not region:isnil(), "could not make a MIDI region")
  local playlist = track:playlist()
  Session:begin_reversible_command("insert region")
  playlist:to_stateful():clear_changes()
  playlist:add_region(region, Temporal.timepos_t(0), 1, false)
  Session:add_stateful_diff_command(playlist:to_statefuldestructible())
  Session:commit_reversible_command(nil)

  local model = region:to_midiregion():model()
  local tempo = Temporal.TempoMap.read()
  local function beats(seconds) return tempo:quarters_at(Temporal.timepos_t(math.floor(seconds * RATE + 0.5))) end
  local command = model:new_note_diff_command("add notes")
  for _, n in ipairs(notes) do
    local from, to = beats(n[3]), beats(n[4])
    command:add(ARDOUR.LuaAPI.new_noteptr(0, from, to - from, n[1], n[2]))
  end
  model:apply_command(Session, command)
  return track, processor
end

local function save_and_render(track, processor)
  settle()
  print_params(processor)
  assert(Session:save_state("", false, false, false, false, false) == 0, "could not save the session")
  render(track)
end

local function create()
  local track, processor = new_session(NOTES)
  -- Ardour must see the latency, to line the track up with the others.
  local latency = processor:signal_latency()
  say("latency: " .. latency)
  assert(latency == LATENCY, "Struck reports " .. latency .. " samples of latency to Ardour, expected " .. LATENCY)
  local plugin = processor:to_insert():plugin(0)
  for _, s in ipairs(SETTINGS) do
    assert(ARDOUR.LuaAPI.set_processor_param(processor, parameter_index(plugin, s[1]), s[2]), "could not set " .. s[1])
  end
  save_and_render(track, processor)
end

-- The hammer's mass stepped from LIGHT to HEAVY at STEP (`steady` nil), or
-- `steady` throughout; with an `early` note (E4 at 1 s) before the step too.
local function automation(steady, early)
  local notes = { { 60, 100, STEP / RATE, STEP / RATE + 1.0 } }
  if early then notes[#notes + 1] = { 64, 90, 1.0, 1.3 } end
  local track, processor = new_session(notes)
  local plugin = processor:to_insert():plugin(0)
  local mass = parameter_index(plugin, "Hammer mass")
  if steady then
    assert(ARDOUR.LuaAPI.set_processor_param(processor, mass, steady), "could not set the mass")
  else
    local list, points = ARDOUR.LuaAPI.plugin_automation(processor, mass)
    assert(not list:isnil(), "no automation for the hammer's mass")
    points:clear_list()
    points:set_interpolation(Evoral.InterpolationStyle.Discrete)
    points:add(Temporal.timepos_t(0), LIGHT, false, false)
    points:add(Temporal.timepos_t(STEP), HEAVY, false, false)
    local port = plugin:nth_parameter(mass, true)
    local control = processor:to_automatable():automation_control(
      Evoral.Parameter(ARDOUR.AutomationType.PluginAutomation, 0, port), false)
    assert(not control:isnil(), "no automation control for the hammer's mass")
    control:set_automation_state(ARDOUR.AutoState.Play)
  end
  save_and_render(track, processor)
end

local function reopen()
  assert(load_session(session_dir, SNAPSHOT), "could not load the session")
  local track = Session:route_by_name("Struck")
  assert(not track:isnil(), "the track is missing")
  local processor = track:nth_plugin(0)
  assert(not processor:isnil(), "Struck did not load")
  settle()
  print_params(processor)
  render(track:to_track())
end

assert(AudioEngine:set_backend("None (Dummy)", "", ""), "no dummy backend")
if mode == "create" then
  create()
elseif mode == "reopen" then
  reopen()
elseif mode == "automate" then
  automation(nil, false)
elseif mode == "steady" then
  automation(HEAVY, false)
elseif mode == "automate-early" then
  automation(nil, true)
elseif mode == "light-early" then
  automation(LIGHT, true)
else
  error("create, reopen, automate, steady, automate-early or light-early")
end
-- Every Lua reference to the session's objects must go before the session
-- closes (they would be destroyed after it).
collectgarbage()
collectgarbage()
Session:close()
say("closed")
