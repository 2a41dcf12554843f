// Independent Fast DDS (eProsima Fast DDS 2.x, Debian libfastrtps-dev: the DDS
// under rmw_fastrtps_cpp, ROS 2's default RMW) peer for the truss_deploy node
// (tests/node_fastdds.rs). No ROS: the types are written by hand from
// msg/*.msg, sensor_msgs/JointState and std_srvs/Trigger with ROS 2's DDS
// mangling (rt/ topics, pkg::msg::dds_::Type_), and the service call is made
// as rmw_fastrtps_cpp makes it (rq/<name>Request, rr/<name>Reply, the request
// written with related_sample_identity.writer_guid = the reply reader's GUID,
// the reply matched by related_sample_identity), with no mapping flag on the
// node.
//
// The peer
//   (a) receives and decodes rt/joint_states,
//   (b) writes a CableForceCommand the moment its writer matches the node's
//       reader, and waits for LockStatus to show it in force (first-sample delay),
//   (b2) then writes one CableSpeedCommand (PEER_SPEED m/s, default 0.02) and
//       reads the `drive_motor` joint on rt/joint_states: its velocity is the
//       speed and its position (the cable reeled in) grows at it for 1 s of
//       simulated time (the node runs a mast that stays taut: node_fastdds.rs),
//   (c) then calls /truss/pause (std_srvs/Trigger) as soon as the service is
//       available (request writer and reply reader matched), twice
//       (first-call and second-call latency),
//   (d) from a second participant, floods malformed CableForceCommand samples
//       at about 10 kHz for 1 s while the first writes 9 valid commands, and
//       reads from LockStatus how many were applied and how many malformed
//       ones were counted (the valid ones end the motor's speed control).
// Every loop is bounded in count and time. Loopback only (127.0.0.1, unicast
// discovery). Env: ROS_DOMAIN_ID, PEER_SECS (default 30). Prints one line
// `SUMMARY {json}`; exit 0 iff (a)-(d) passed.
#include "common.hpp"

// ---- message types (field order = .msg order; CDR is positional) ----
struct JointState {  // sensor_msgs/msg/JointState
    Header header;
    std::vector<std::string> name;
    std::vector<double> position, velocity, effort;
    void serialize(Cdr& c) const { ser(c, header); c << name << position << velocity << effort; }
    void deserialize(Cdr& c) { de(c, header); c >> name >> position >> velocity >> effort; }
    static const char* type() { return "sensor_msgs::msg::dds_::JointState_"; }
};

struct CableForceCommand {  // msg/CableForceCommand.msg
    std::vector<std::string> names;
    std::vector<double> tensions_n;
    void serialize(Cdr& c) const { c << names << tensions_n; }
    void deserialize(Cdr& c) { c >> names >> tensions_n; }
    static const char* type() { return "truss_deploy::msg::dds_::CableForceCommand_"; }
};

struct CableSpeedCommand {  // msg/CableSpeedCommand.msg
    std::vector<std::string> names;
    std::vector<double> speeds_m_s;
    void serialize(Cdr& c) const { c << names << speeds_m_s; }
    void deserialize(Cdr& c) { c >> names >> speeds_m_s; }
    static const char* type() { return "truss_deploy::msg::dds_::CableSpeedCommand_"; }
};

// Not a CableForceCommand: a names sequence that claims 2^32-16 strings in a
// 12-byte payload. Same type name, so the node's reader matches the writer
// and cannot decode what it receives.
struct MalformedCommand {
    uint32_t claimed_len = 0xFFFFFFF0u;
    void serialize(Cdr& c) const { c << claimed_len << uint32_t(7) << uint32_t(0); }
    void deserialize(Cdr& c) { c >> claimed_len; }
    static const char* type() { return CableForceCommand::type(); }
};

struct LockStatus {  // msg/LockStatus.msg
    Header header;
    std::vector<std::string> names;
    std::vector<bool> locked;
    std::vector<double> time_s, impulse_ns, energy_lost_j;
    bool deployed = false, paused = false;
    std::vector<std::string> cable_names;
    std::vector<double> cable_tensions_n;
    uint32_t accepted_commands = 0, rejected_commands = 0, rejected_unknown_cable = 0,
             rejected_mismatched_lengths = 0, rejected_bad_tension = 0, rejected_malformed = 0,
             rejected_bad_speed = 0;
    void serialize(Cdr&) const {}
    void deserialize(Cdr& c) {
        de(c, header);
        c >> names >> locked >> time_s >> impulse_ns >> energy_lost_j >> deployed >> paused >>
            cable_names >> cable_tensions_n >> accepted_commands >> rejected_commands >>
            rejected_unknown_cable >> rejected_mismatched_lengths >> rejected_bad_tension;
        if (!std::getenv("PEER_LOCKSTATUS_WITHOUT_MALFORMED")) c >> rejected_malformed;  // (main before #14)
        if (!std::getenv("PEER_LOCKSTATUS_WITHOUT_MALFORMED")) c >> rejected_bad_speed;  // (issue 30)
    }
    static const char* type() { return "truss_deploy::msg::dds_::LockStatus_"; }
};

struct TriggerRequest {  // std_srvs/srv/Trigger request: an empty struct is one byte
    uint8_t structure_needs_at_least_one_member = 0;
    void serialize(Cdr& c) const { c << structure_needs_at_least_one_member; }
    void deserialize(Cdr& c) { c >> structure_needs_at_least_one_member; }
    static const char* type() { return "std_srvs::srv::dds_::Trigger_Request_"; }
};
struct TriggerResponse {
    bool success = false;
    std::string message;
    void serialize(Cdr& c) const { c << success << message; }
    void deserialize(Cdr& c) { c >> success >> message; }
    static const char* type() { return "std_srvs::srv::dds_::Trigger_Response_"; }
};

int main() {
    const char* d = std::getenv("ROS_DOMAIN_ID");
    const int domain = d ? std::atoi(d) : 0;
    const char* b = std::getenv("PEER_SECS");
    const double budget_s = b ? std::atof(b) : 30.0;
    const double tension = 0.0123;  // below the mast's 0.02 N: it must not deploy in the test
    const char* sp = std::getenv("PEER_SPEED");
    const double speed = sp ? std::atof(sp) : 0.02;

    DomainParticipant* p = make_participant(domain, "fastdds_peer");
    DomainParticipant* flooder = make_participant(domain, "fastdds_flooder");
    if (!p || !flooder) {
        log("cannot create participants");
        return 2;
    }
    Publisher* pub = p->create_publisher(PUBLISHER_QOS_DEFAULT);
    Subscriber* sub = p->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
    DataReader* js_r = sub->create_datareader(topic<JointState>(p, "rt/joint_states"), reader_qos());
    DataReader* lock_r =
        sub->create_datareader(topic<LockStatus>(p, "rt/truss/lock_status"), reader_qos(true, 1));
    DataWriter* cmd_w =
        pub->create_datawriter(topic<CableForceCommand>(p, "rt/truss/cable_force_cmd"), writer_qos());
    DataWriter* speed_w =
        pub->create_datawriter(topic<CableSpeedCommand>(p, "rt/truss/cable_speed_cmd"), writer_qos());
    DataWriter* rq_w =
        pub->create_datawriter(topic<TriggerRequest>(p, "rq/truss/pauseRequest"), writer_qos(false, 1000));
    DataReader* rr_r =
        sub->create_datareader(topic<TriggerResponse>(p, "rr/truss/pauseReply"), reader_qos(false, 1000));
    DataWriter* bad_w = flooder->create_publisher(PUBLISHER_QOS_DEFAULT)
                            ->create_datawriter(topic<MalformedCommand>(flooder, "rt/truss/cable_force_cmd"),
                                                writer_qos());
    if (!js_r || !lock_r || !cmd_w || !speed_w || !rq_w || !rr_r || !bad_w) {
        log("cannot create endpoints");
        return 2;
    }
    const auto reply_reader_guid = rr_r->guid();

    const auto t0 = Clock::now();
    int n_js = 0;
    std::vector<std::string> js_names;
    double cmd_matched_s = -1, cmd_sent_s = -1, cmd_applied_s = -1;
    // speed phase: the drive_motor joint after the speed command
    double speed_sent_s = -1;
    bool speed_done = false;
    int speed_samples = 0;
    double speed_vel_err = 0, speed_t0 = -1, speed_x0 = 0, speed_t1 = -1, speed_x1 = 0;
    double srv_available_s = -1;
    std::vector<double> call_latency_s;
    std::vector<std::string> call_messages;
    int64_t pending_seq = -1;
    double pending_sent_s = -1;
    LockStatus last_lock;
    bool have_lock = false;
    // flood phase
    bool flood_done = false;
    int flood_sent = 0, valid_sent = 0;
    uint32_t accepted_before_flood = 0;
    double last_valid_tension = -1;
    double flood_end_s = -1;
    bool flood_checked = false;
    uint32_t valid_applied = 0, malformed_counted = 0;
    bool last_valid_in_force = false;

    for (int iter = 0; iter < 200000; ++iter) {
        const double now = secs_since(t0);
        if (now > budget_s) break;
        // (a) joint states
        {
            JointState js;
            SampleInfo si;
            for (int k = 0; k < 100 && js_r->take_next_sample(&js, &si) == ReturnCode_t::RETCODE_OK; ++k) {
                if (si.valid_data) {
                    ++n_js;
                    js_names = js.name;
                    // (b2) once the motor runs at the speed, every later sample must
                    size_t k = 0;
                    while (k < js.name.size() && js.name[k] != "drive_motor") ++k;
                    if (speed_sent_s >= 0 && !speed_done && k < js.velocity.size() && k < js.position.size()) {
                        const double t = js.header.stamp.sec + 1e-9 * js.header.stamp.nanosec;
                        const double err = std::fabs(js.velocity[k] - speed);
                        if (speed_t0 < 0 && err <= 1e-9) {
                            speed_t0 = t;
                            speed_x0 = js.position[k];
                        }
                        if (speed_t0 >= 0 && t > speed_t0) {
                            ++speed_samples;
                            speed_vel_err = std::max(speed_vel_err, err);
                            speed_t1 = t;
                            speed_x1 = js.position[k];
                            if (speed_t1 - speed_t0 >= 1.0) {
                                speed_done = true;
                                log("speed phase: " + std::to_string(speed_samples) + " samples over " +
                                    std::to_string(speed_t1 - speed_t0) + " s simulated");
                            }
                        }
                    }
                }
            }
        }
        {
            LockStatus ls;
            SampleInfo si;
            for (int k = 0; k < 100 && lock_r->take_next_sample(&ls, &si) == ReturnCode_t::RETCODE_OK; ++k) {
                if (si.valid_data) {
                    last_lock = ls;
                    have_lock = true;
                }
            }
        }
        // (b) a command the moment the writer matches
        if (cmd_sent_s < 0) {
            PublicationMatchedStatus st;
            cmd_w->get_publication_matched_status(st);
            if (st.current_count > 0) {
                cmd_matched_s = now;
                CableForceCommand c;
                c.names = {"drive"};
                c.tensions_n = {tension};
                cmd_w->write(&c);
                cmd_sent_s = secs_since(t0);
                log("command writer matched at " + std::to_string(cmd_matched_s) + " s; command written");
            }
        }
        if (cmd_sent_s >= 0 && cmd_applied_s < 0 && have_lock && last_lock.cable_tensions_n.size() == 1 &&
            last_lock.cable_tensions_n[0] == tension && last_lock.accepted_commands >= 1) {
            cmd_applied_s = now;
            log("command in force (LockStatus) " + std::to_string(cmd_applied_s - cmd_sent_s) +
                " s after it was written");
        }
        // (b2) one speed command once the force command is in force
        if (cmd_applied_s >= 0 && speed_sent_s < 0) {
            PublicationMatchedStatus st;
            speed_w->get_publication_matched_status(st);
            if (st.current_count > 0) {
                CableSpeedCommand c;
                c.names = {"drive"};
                c.speeds_m_s = {speed};
                speed_w->write(&c);
                speed_sent_s = now;
                log("speed command written");
            }
        }
        // (c) service calls as rmw_fastrtps makes them (after the speed phase,
        // which needs the simulation running)
        if (srv_available_s < 0 && speed_done) {
            PublicationMatchedStatus ps;
            SubscriptionMatchedStatus ss;
            rq_w->get_publication_matched_status(ps);
            rr_r->get_subscription_matched_status(ss);
            if (ps.current_count > 0 && ss.current_count > 0) {
                srv_available_s = now;
                log("service /truss/pause available at " + std::to_string(now) + " s");
            }
        }
        if (srv_available_s >= 0 && pending_seq < 0 && call_latency_s.size() < 2) {
            TriggerRequest rq;
            eprosima::fastrtps::rtps::WriteParams wp;
            wp.related_sample_identity().writer_guid() = reply_reader_guid;
            if (rq_w->write(&rq, wp)) {
                const auto& sn = wp.sample_identity().sequence_number();
                pending_seq = (int64_t(sn.high) << 32) | sn.low;
                pending_sent_s = secs_since(t0);
            }
        }
        if (pending_seq >= 0) {
            TriggerResponse r;
            SampleInfo si;
            for (int k = 0; k < 10 && rr_r->take_next_sample(&r, &si) == ReturnCode_t::RETCODE_OK; ++k) {
                const auto& rel = si.related_sample_identity;
                const int64_t seq =
                    (int64_t(rel.sequence_number().high) << 32) | rel.sequence_number().low;
                // rmw_fastrtps accepts a reply whose related writer GUID is its reply
                // reader's (or its request writer's) and matches the request's number.
                const bool mine = rel.writer_guid() == reply_reader_guid || rel.writer_guid() == rq_w->guid();
                if (si.valid_data && mine && seq == pending_seq) {
                    // the first call's latency counts from availability (a client
                    // calls as soon as wait_for_service returns)
                    const double from = call_latency_s.empty() ? srv_available_s : pending_sent_s;
                    call_latency_s.push_back(secs_since(t0) - from);
                    call_messages.push_back((r.success ? "ok: " : "FAILED: ") + r.message);
                    log("pause reply " + std::to_string(call_latency_s.back()) + " s: " + r.message);
                    pending_seq = -1;
                } else if (si.valid_data) {
                    log("reply not for this request (seq " + std::to_string(seq) + ")");
                }
            }
        }
        // (d) malformed flood with 9 valid commands in it
        if (!flood_done && cmd_applied_s >= 0 && call_latency_s.size() == 2) {
            PublicationMatchedStatus st;
            bad_w->get_publication_matched_status(st);
            if (st.current_count > 0 && have_lock) {
                accepted_before_flood = last_lock.accepted_commands;
                const auto fs = Clock::now();
                MalformedCommand bad;
                for (int k = 0; k < 10000 && secs_since(fs) < 3.0; ++k) {
                    bad_w->write(&bad);
                    ++flood_sent;
                    if (k % 1000 == 500) {
                        CableForceCommand c;
                        c.names = {"drive"};
                        last_valid_tension = tension + 1e-4 * (valid_sent + 1);
                        c.tensions_n = {last_valid_tension};
                        cmd_w->write(&c);
                        ++valid_sent;
                    }
                    if (k % 10 == 9) std::this_thread::sleep_for(std::chrono::microseconds(1000));
                }
                flood_done = true;
                flood_end_s = secs_since(t0);
                log("flood: " + std::to_string(flood_sent) + " malformed and " + std::to_string(valid_sent) +
                    " valid commands in " + std::to_string(secs_since(fs)) + " s");
            }
        }
        if (flood_done && !flood_checked && have_lock) {
            valid_applied = last_lock.accepted_commands - accepted_before_flood;
            malformed_counted = last_lock.rejected_malformed;
            last_valid_in_force =
                last_lock.cable_tensions_n.size() == 1 && last_lock.cable_tensions_n[0] == last_valid_tension;
            if ((valid_applied >= uint32_t(valid_sent) && last_valid_in_force) || now > flood_end_s + 5.0)
                flood_checked = true;
        }
        if (n_js >= 20 && flood_checked) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }

    const bool calls_ok = call_latency_s.size() == 2 && call_messages[0].rfind("ok: ", 0) == 0;
    const double speed_rate = speed_done ? (speed_x1 - speed_x0) / (speed_t1 - speed_t0) : 0.0;
    const bool speed_ok = speed_done && speed_vel_err <= 1e-9 && std::fabs(speed_rate - speed) <= 1e-6;
    const bool ok = n_js >= 20 && cmd_applied_s >= 0 && speed_ok && calls_ok && flood_checked &&
                    last_valid_in_force && valid_applied == uint32_t(valid_sent) && malformed_counted > 0;
    std::ostringstream js;
    js << "{\"joint_states\":" << n_js << ",\"joint_names\":[";
    for (size_t i = 0; i < js_names.size(); ++i) js << (i ? "," : "") << json_str(js_names[i]);
    js << "],\"command_matched_s\":" << cmd_matched_s
       << ",\"command_to_in_force_s\":" << (cmd_applied_s >= 0 ? cmd_applied_s - cmd_sent_s : -1)
       << ",\"speed_m_s\":" << speed << ",\"speed_done\":" << (speed_done ? "true" : "false")
       << ",\"speed_samples\":" << speed_samples << ",\"speed_velocity_max_err\":" << speed_vel_err
       << ",\"speed_reel_in_rate\":" << speed_rate << ",\"speed_sim_s\":" << (speed_t1 - speed_t0)
       << ",\"service_available_s\":" << srv_available_s << ",\"call_latency_s\":[";
    for (size_t i = 0; i < call_latency_s.size(); ++i) js << (i ? "," : "") << call_latency_s[i];
    js << "],\"call_messages\":[";
    for (size_t i = 0; i < call_messages.size(); ++i) js << (i ? "," : "") << json_str(call_messages[i]);
    js << "],\"flood_malformed_sent\":" << flood_sent << ",\"flood_valid_sent\":" << valid_sent
       << ",\"flood_valid_applied\":" << valid_applied << ",\"flood_last_valid_in_force\":"
       << (last_valid_in_force ? "true" : "false") << ",\"rejected_malformed\":" << malformed_counted
       << ",\"paused\":" << (have_lock && last_lock.paused ? "true" : "false") << ",\"result\":\""
       << (ok ? "PASS" : "FAIL") << "\"}";
    std::printf("SUMMARY %s\n", js.str().c_str());
    std::fflush(stdout);
    p->delete_contained_entities();
    flooder->delete_contained_entities();
    DomainParticipantFactory::get_instance()->delete_participant(p);
    DomainParticipantFactory::get_instance()->delete_participant(flooder);
    return ok ? 0 : 1;
}
